"""Real time under load (issue 12): does anything the web process does delay a sample?

A real ``elab serve`` with 100 real-time flexible-link runs (Ts = 1 ms), each followed by
one watcher from sample 0 (the client process of :mod:`tests.bench.wsload`). Two minutes
are measured:

- **quiet**: the runs and their watchers alone;
- **loaded**: the same, while rounds of requests run back to back, each round at once:
  a JSON download of a finished 1,000,000-sample run (read and discarded as it comes), a
  16 MiB identification upload (a CSV file, parsed only), an identification of 100,000
  samples (an ARX order search over 1,000 structures and two models), and a burst of
  1,000 bad requests (50 at a time: deep JSON, huge numbers, unknown ids, bad queries).

Per minute: how late the engine's ticks began (``GET /api/v1/server``, which reports the
last minute: each window is a whole minute), the web process's resident memory (at the
start, at its peak, and after the load), CPU of the web process and of the engine; then
every run is stopped, every watcher's samples counted and every recording compared row by
row with the run simulated offline.
"""

from __future__ import annotations

import asyncio
import json
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

from tests.api.server import Server, until
from tests.bench.server import (
    FLEX,
    Clients,
    check_recordings,
    cpu_seconds,
    http,
    lab_server,
    start_runs,
)

RUNS = 100
WINDOW = 62.0  # s: a little over the minute /server reports, so it lies inside one phase
BIG_RUN = 1000.0  # s at 1 kHz: the 1,000,000-sample run downloaded as JSON


def rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for {pid}")


def upload_16mib() -> dict[str, Any]:
    rng = np.random.default_rng(1)
    rows, size = [], 0
    while size < 15.9 * 2**20:  # the body (the text, JSON-escaped) just under 16 MiB
        u, y = rng.standard_normal(2)
        row = f"{u:.6f},{y:.6f}"
        rows.append(row)
        size += len(row) + 2  # "\n" is 2 bytes in JSON
    text = "# sample time: 0.01 s\nu,y\n" + "\n".join(rows)
    return {
        "data": {"source": "file", "text": text, "input": ["u"], "output": ["y"]},
        "correlation": False,
        "spectral": False,
    }


def ident_100k() -> dict[str, Any]:
    rng = np.random.default_rng(2)
    u = rng.standard_normal(100_000)
    y = np.convolve(u, [0, 0.5, 0.3, 0.1])[:100_000] + 0.1 * rng.standard_normal(100_000)
    text = "# sample time: 0.01 s\nu,y\n" + "\n".join(
        f"{a:.6f},{b:.6f}" for a, b in zip(u, y, strict=True)
    )
    return {
        "data": {"source": "file", "text": text, "input": ["u"], "output": ["y"]},
        "arx_search": {"na": [1, 10], "nb": [1, 10], "nk": [1, 10]},
        "models": [
            {"kind": "arx", "na": 3, "nb": 3, "nk": 1},
            {"kind": "n4sid", "order": 3, "horizon": 0},
        ],
    }


BAD: list[tuple[str, str, str | None]] = [
    ("POST", "/runs", "[" * 5000 + "]" * 5000),
    ("POST", "/runs", '{"plant": "flexible_link", "seed": 1' + "0" * 5000 + "}"),
    ("POST", "/runs", '{"plant": "nope"}'),
    ("POST", "/runs", '{"plant": "flexible_link", "Ts": 1e-300}'),
    ("POST", "/runs/r-000000000000/stop", None),
    ("GET", "/runs?limit=%C2%B2", None),
    ("GET", "/runs/r-000000000000/data?format=xls", None),
    ("POST", "/plants/flexible_link/design/place", '{"poles": [{"re": 1e308, "im": 0}]}'),
    (
        "POST",
        "/ident",
        '{"data": {"source": "file", "text": "u,y\\n1,x", "input": ["u"], "output": ["y"]}}',
    ),
    ("GET", "/plants/flexible_link/bode?output=alpha2", None),
]


async def bad_burst(url: str, n: int = 1000, at_once: int = 50) -> dict[int, int]:
    codes: dict[int, int] = {}
    gate = asyncio.Semaphore(at_once)
    async with httpx.AsyncClient(base_url=url + "/api/v1", timeout=120) as c:

        async def one(i: int) -> None:
            method, path, body = BAD[i % len(BAD)]
            async with gate:
                r = await c.request(
                    method, path, content=body, headers={"content-type": "application/json"}
                )
            codes[r.status_code] = codes.get(r.status_code, 0) + 1

        await asyncio.gather(*(one(i) for i in range(n)))
    return codes


def one_round(
    server: Server, big_run: str, upload: dict[str, Any], ident: dict[str, Any]
) -> dict[str, Any]:
    """The four loads, started together; what each answered."""
    out: dict[str, Any] = {}

    def download() -> None:
        size = 0
        with httpx.stream(
            "GET",
            f"{server.url}/api/v1/runs/{big_run}/data",
            params={"format": "json"},
            timeout=600,
        ) as r:
            for part in r.iter_bytes():
                size += len(part)
        out["download_mb"] = size / 1e6

    def post(name: str, body: dict[str, Any]) -> None:
        r = httpx.post(server.url + "/api/v1/ident", json=body, timeout=600)
        out[name] = r.status_code

    def burst() -> None:
        out["bad"] = asyncio.run(bad_burst(server.url))

    threads = [
        threading.Thread(target=download),
        threading.Thread(target=burst),
        threading.Thread(target=post, args=("upload", upload)),
        threading.Thread(target=post, args=("ident", ident)),
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return out


def bench_load() -> dict[str, Any]:
    upload, ident = upload_16mib(), ident_100k()
    with tempfile.TemporaryDirectory() as tmp:
        server = lab_server(Path(tmp) / "data", RUNS)
        assert server.proc is not None
        web = server.proc.pid
        try:
            with http(server) as c:
                big = (
                    c.post("/runs", json={"plant": FLEX.id, "pace": "fast", "duration": BIG_RUN})
                    .raise_for_status()
                    .json()
                )
                until(lambda: c.get(f"/runs/{big['id']}").json()["status"] == "finished", 600)
            engine = server.engine_pid
            runs = start_runs(server, RUNS)
            clients = Clients(
                [f"{server.ws_url}{r['stream_url']}?from_seq=0" for r in runs],
                Path(tmp) / "frames.npz",
            )
            clients.wait_ready()
            quiet = phase(server, web, engine, WINDOW, None)
            rounds: list[dict[str, Any]] = []

            def load() -> None:
                t_end = time.monotonic() + WINDOW
                while time.monotonic() < t_end:
                    rounds.append(one_round(server, big["id"], upload, ident))

            loaded = phase(server, web, engine, WINDOW, load)
            time.sleep(5.0)  # the last answers drain; what the web process keeps
            after_mib = rss_mib(web)
            with http(server) as c:
                for run in runs:
                    c.post(f"/runs/{run['id']}/stop").raise_for_status()
            frames = clients.result(timeout=300)
            rec = check_recordings(server, runs)
        finally:
            server.stop()
    return {
        "quiet": quiet,
        "loaded": loaded,
        "rounds": rounds,
        "after_mib": after_mib,
        "watch_missing": int(frames["missing"].sum()),
        "skipped": int(frames["skipped"].sum()),
        "short": int(((frames["next_k"] != frames["end_k"]) | (frames["errors"] > 0)).sum()),
        **{f"rec_{k}": v for k, v in rec.items()},
    }


def phase(server: Server, web: int, engine: int, seconds: float, load: Any) -> dict[str, float]:
    """One window: the web process's memory (start, peak), both processes' CPU, and the
    engine's tick lateness over the minute that ends with it."""
    start_mib, peak = rss_mib(web), rss_mib(web)
    c0 = {"web": cpu_seconds(web), "engine": cpu_seconds(engine)}
    t0 = time.monotonic()
    worker = threading.Thread(target=load) if load else None
    if worker:
        worker.start()
    while time.monotonic() - t0 < seconds or (worker and worker.is_alive()):
        peak = max(peak, rss_mib(web))
        time.sleep(0.2)
    wall = time.monotonic() - t0
    cpu = {k: (cpu_seconds(pid) - c0[k]) / wall for k, pid in (("web", web), ("engine", engine))}
    timing = server.status()["stepper"]
    return {
        "start_mib": start_mib,
        "peak_mib": peak,
        "wall": wall,
        "web_core": cpu["web"],
        "engine_core": cpu["engine"],
        **timing,
    }


def load_section() -> str:
    r = bench_load()
    q, ld = r["quiet"], r["loaded"]
    rounds = r["rounds"]
    bad = {}
    for rd in rounds:
        for code, n in rd["bad"].items():
            bad[code] = bad.get(code, 0) + n
    answers = ", ".join(f"{n:,} × {code}" for code, n in sorted(bad.items()))
    growth = (r["after_mib"] / ld["start_mib"] - 1) * 100

    def row(label: str, key: str, fmt: str, goal: str = "") -> str:
        return f"| {label} | {format(q[key], fmt)} | {format(ld[key], fmt)} | {goal} |"

    rec = (
        f"{r['rec_missing']:.0f} missing, {r['rec_differing']:.0f} differing of "
        f"{r['rec_recorded']:,.0f} rows"
    )
    return f"""## Real time under load (issue 12)

A real `elab serve`: the web process (uvicorn) and its engine process (stepping and
recording). {RUNS} real-time flexible-link runs at 1 kHz, each followed live by one
watcher from sample 0 (the client process of `tests/bench/wsload.py`). Two windows of
{WINDOW:.0f} s: *quiet* (the runs alone) and *loaded*, where rounds of four loads run back
to back, each round at once: a JSON download of a finished 1,000,000-sample run
({rounds[0]["download_mb"] if rounds else 0:.0f} MB, read as it streams), a 16 MiB
identification upload (parsed in the identification worker), an identification of 100,000
samples (ARX order search over 1,000 structures, ARX and subspace models) and a burst of
1,000 bad requests, 50 at a time. The engine's lateness is `GET /api/v1/server`'s minute,
which lies inside each window.

| figure | quiet | loaded | goal |
|---|---|---|---|
{row("engine ticks late, p99 (ms)", "late_p99_ms", ".2f", "≤ 5")}
{row("engine ticks late, max (ms)", "late_max_ms", ".1f", "≤ 20")}
{row("engine ticks late, median (ms)", "late_p50_ms", ".2f")}
{row("run clock drift (ms per minute)", "drift_ms_per_min", ".3f")}
{row("web process CPU, share of one core", "web_core", ".2f")}
{row("engine process CPU, share of one core", "engine_core", ".2f")}
{row("web process memory at the start (MiB)", "start_mib", ".0f")}
{row("web process memory, peak (MiB)", "peak_mib", ".0f")}
| web process memory 5 s after the load (MiB) | — | {r["after_mib"]:.0f} ({growth:+.1f} % of its start) | within 10 % |
| rounds of the four loads in the window | — | {len(rounds)} | |
| samples missing at the watchers | {r["watch_missing"]} (whole run) | | 0 |
| watchers that missed the end, or got an error | {r["short"]} | | 0 |
| recordings vs offline simulation | {rec} | | 0 missing |

The bad requests were answered {answers}; the uploads
{sorted({rd["upload"] for rd in rounds})} and identifications
{sorted({rd["ident"] for rd in rounds})} (status codes).
"""


if __name__ == "__main__":
    print(json.dumps({k: v for k, v in bench_load().items() if k != "rounds"}, indent=1))
