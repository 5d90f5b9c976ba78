"""Issue 28's start-up benchmark: ``elab serve`` to its first answer, against a minimal
uvicorn + starlette app started the same way.

Each a fresh process on a free loopback port and a fresh data directory (the embedded
SQLite default, no rig), polled every 10 ms from outside: the time to the first 200 of
``GET /api/v1/me`` (the peer: ``GET /``), then for E-Lab the time until ``/api/v1/health``
is 200 (the engine up: a run can start) and the first Bode of the flexible link (the
first analysis imports python-control). min / median / max of 3, interleaved.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from collections.abc import Callable
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tests.api.server import TLS, free_port  # noqa: E402

ELAB = str(Path(sys.executable).parent / "elab")
REPEAT = 3
CAP = 120.0  # s: a cap, not an expectation

PEER = textwrap.dedent(
    """
    import sys
    import uvicorn
    from starlette.applications import Starlette
    from starlette.responses import JSONResponse
    from starlette.routing import Route

    async def home(request):
        return JSONResponse({"ok": True})

    app = Starlette(routes=[Route("/", home)])
    uvicorn.run(app, host="127.0.0.1", port=int(sys.argv[1]), log_level="warning")
    """
)


def _until(ok: Callable[[], bool], t0: float) -> float:
    while time.perf_counter() - t0 < CAP:
        try:
            if ok():
                return time.perf_counter() - t0
        except httpx.HTTPError:
            pass
        time.sleep(0.01)
    raise RuntimeError(f"not ready in {CAP:g} s")


def _get(url: str) -> bool:
    return httpx.get(url, timeout=5, verify=TLS).status_code == 200


def _elab() -> tuple[float, float, float]:
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    with tempfile.TemporaryDirectory() as data:
        env = {**os.environ, "ELAB_DATA": data, "ELAB_RIG": "none"}
        t0 = time.perf_counter()
        proc = subprocess.Popen(
            [ELAB, "serve", "--port", str(port)],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            first = _until(lambda: _get(url + "/api/v1/me"), t0)
            health = _until(lambda: _get(url + "/api/v1/health"), t0)
            t1 = time.perf_counter()
            _get(url + "/api/v1/plants/flexible_link/bode")
            bode = time.perf_counter() - t1
        finally:
            proc.terminate()
            proc.wait(30)
    return first, health, bode


def _peer() -> float:
    port = free_port()
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", PEER, str(port)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        return _until(lambda: _get(f"http://127.0.0.1:{port}/"), t0)
    finally:
        proc.terminate()
        proc.wait(30)


def _spread(xs: list[float]) -> str:
    return " / ".join(f"{x:.2f}" for x in (min(xs), statistics.median(xs), max(xs)))


def bench_startup() -> str:
    """The markdown section of docs/benchmarks.md for issue 28's start-up goal."""
    load0 = os.getloadavg()[0]
    elab, peer = [], []
    for _ in range(REPEAT):
        elab.append(_elab())
        peer.append(_peer())
    first, health, bode = ([x[i] for x in elab] for i in range(3))
    ratio = statistics.median(first) / statistics.median(peer)
    return f"""## Start-up (issue 28)

`elab serve` (a fresh data directory, no rig) and a minimal uvicorn + starlette app, each
started as a process and polled from outside every 10 ms (`tests/bench/startup.py`);
seconds, min / median / max of {REPEAT}, interleaved.

| measure | E-Lab | peer: starlette alone | goal |
|---|---|---|---|
| to the first 200 | {_spread(first)} | {_spread(peer)} | ≤ 1 s |
| **ratio of the medians** | **{ratio:.1f}×** | 1 | |
| to `/health` 200 (the engine up: runs can start) | {_spread(health)} | | |
| then the first Bode (imports python-control) | {_spread(bode)} | | |

Load average {load0:.1f} before, {os.getloadavg()[0]:.1f} after.
"""
