"""Issue 28's download benchmark: a finished run's recording from a real ``elab serve`` on
loopback, in every format, with and without gzip, against ``np.savetxt`` and
``json.dumps`` of the same columns in this process.

The runs: the flexible link at its 1 kHz sample time, stepped at the fast pace with
sensor noise (every value a full 17-digit double). Each download is read raw by httpx
(not decompressed: the client's work is not the server's) and timed from the request to
the last byte. The web process's memory: its peak resident size during the download
(``VmHWM`` after ``clear_refs``) minus its size before. min / median / max of 3,
interleaved.
"""

from __future__ import annotations

import io
import json
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import httpx
import numpy as np
import scipy.io

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tests.api.server import TLS, Server, until  # noqa: E402

SIZES = (10_000, 100_000, 1_000_000)  # samples, against the peers too
LARGEST = 3_600_000  # the longest run the lab allows (1 h at 1 kHz): without the peers
REPEAT = 3
FORMATS = ("csv", "json", "mat")
MiB = 2**20


def _status(pid: int, key: str) -> int:
    """``key`` (e.g. ``VmRSS``) of a process, bytes."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) * 1024
    raise KeyError(key)


def _make_run(c: httpx.Client, samples: int) -> str:
    Ts = c.get("/plants/flexible_link").json()["Ts"]
    body = {
        "plant": "flexible_link",
        "duration": samples * Ts,
        "pace": "fast",
        "noise": True,
        "seed": 1,
    }
    r = c.post("/runs", json=body)
    r.raise_for_status()
    run_id: str = r.json()["id"]
    until(lambda: c.get(f"/runs/{run_id}").json()["status"] == "finished", 600, 0.5)
    return run_id


def _download(server: Server, run_id: str, fmt: str, gzip: bool) -> tuple[float, int, int]:
    """(s to the last byte, bytes sent, the web process's growth in bytes)."""
    assert server.proc is not None
    pid = server.proc.pid
    Path(f"/proc/{pid}/clear_refs").write_text("5")  # the peak resident size from here
    before = _status(pid, "VmRSS")
    headers = {"accept-encoding": "gzip" if gzip else "identity"}
    url = f"{server.url}/api/v1/runs/{run_id}/data?format={fmt}"
    sent = 0
    t0 = time.perf_counter()
    with httpx.stream("GET", url, headers=headers, timeout=600, verify=TLS) as r:
        r.raise_for_status()
        assert (r.headers.get("content-encoding") == "gzip") == gzip, r.headers
        for part in r.iter_raw(1 << 20):
            sent += len(part)
    took = time.perf_counter() - t0
    return took, sent, _status(pid, "VmHWM") - before


def _columns(server: Server, run_id: str) -> dict[str, np.ndarray]:
    """The run's columns, ``t`` first (from its .mat)."""
    r = httpx.get(f"{server.url}/api/v1/runs/{run_id}/data?format=mat", timeout=600, verify=TLS)
    mat = scipy.io.loadmat(io.BytesIO(r.content))
    names = [str(c.item()) for c in mat["channels"].ravel()]
    return {name: mat[name][:, 0] for name in ["t", *names]}


def _peers(columns: dict[str, np.ndarray]) -> dict[str, Callable[[], object]]:
    table = np.column_stack(list(columns.values()))
    return {
        "csv": lambda: np.savetxt(io.BytesIO(), table, delimiter=","),
        "json": lambda: json.dumps({name: v.tolist() for name, v in columns.items()}),
    }


def _timed(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _spread(xs: list[float]) -> str:
    return " / ".join(f"{x:.2f}" for x in (min(xs), statistics.median(xs), max(xs)))


def bench_downloads() -> str:
    """The markdown section of docs/benchmarks.md for issue 28's download goal."""
    load0 = os.getloadavg()[0]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        env = {"ELAB_RIG": "none", "ELAB_MAX_STORAGE_PER_IDENTITY": str(8 << 30)}
        server = Server(Path(tmp) / "data", **env).start()
        try:
            with server.client() as c:
                runs = {n: _make_run(c, n) for n in (*SIZES, LARGEST)}
            for n in (*SIZES, LARGEST):
                peers = _peers(_columns(server, runs[n])) if n in SIZES else {}
                got: dict[tuple[str, bool], list[tuple[float, int, int]]] = {}
                peer_times: dict[str, list[float]] = {}
                for _ in range(REPEAT):
                    for fmt in FORMATS:
                        for gz in (False, True):
                            got.setdefault((fmt, gz), []).append(
                                _download(server, runs[n], fmt, gz)
                            )
                        if fmt in peers:
                            peer_times.setdefault(fmt, []).append(_timed(peers[fmt]))
                for fmt in FORMATS:
                    for gz in (False, True):
                        times = [x[0] for x in got[fmt, gz]]
                        growth = max(x[2] for x in got[fmt, gz]) / MiB
                        peer = peer_times.get(fmt)
                        ratio = (
                            f"{statistics.median(times) / statistics.median(peer):.2f}×"
                            if peer
                            else ""
                        )
                        rows.append(
                            f"| {n:,} | {fmt} | {'gzip' if gz else 'none'} | {_spread(times)} "
                            f"| {got[fmt, gz][0][1] / 1e6:.1f} | {growth:+.1f} "
                            f"| {_spread(peer) if peer and not gz else ''} "
                            f"| {ratio if not gz else ''} |"
                        )
        finally:
            server.stop()
    table = "\n".join(rows)
    return f"""## Downloads (issue 28)

A finished run of the flexible link (1 kHz, sensor noise: full 17-digit doubles, 10
columns with t) downloaded from a real `elab serve` on loopback
(`tests/bench/downloads.py`): seconds from the request to the last byte, min / median /
max of {REPEAT} (up to {LARGEST:,} samples, the longest run allowed); MB on the wire;
the web process's peak resident growth during the download (the largest seen). Peers,
in this process on the same columns: `np.savetxt` (its default `%.18e`) for CSV,
`json.dumps` of the columns as lists for JSON (up to 10⁶ samples). Goals: CSV ≤ `np.savetxt`, JSON ≤
`json.dumps`, .mat ≤ 1 s at 10⁶ samples; growth ≤ +16 MiB at any length.

| samples | format | gzip | s | MB sent | growth MiB | peer s | ratio to the peer |
|---:|---|---|---|---:|---:|---|---:|
{table}

Load average {load0:.1f} before, {os.getloadavg()[0]:.1f} after.
"""
