"""Live-server benchmark (issue 3): a real ``elab serve`` under websocket load.

Two scenarios on the flexible link (predefined controller, default reference,
Ts = 1 ms, pace ``realtime``): many runs with one watcher each, and one run
with many watchers. Every watcher joins at sample 0 (``from_seq=0``). The
clients live in one separate asyncio process (:mod:`tests.bench.wsload`). Over
a steady-state window (all watchers connected and caught up, until the first
run ends) this measures:

- server CPU: utime + stime of the server's processes (the web process and its engine)
  from ``/proc/<pid>/stat``,
  as a share of one core and per websocket message (frames received by all
  clients in the window);
- latency: receipt wall time of each frame minus the wall time of its last
  sample, ``started_at + k·Ts`` (``started_at`` is the server's wall clock at
  sample 0 of a real-time run);
- drift: slope (Theil–Sen) of each watcher's latency floor (minimum per 5 s)
  against sample time, in ms per minute of run time;
- completeness: samples missing at each watcher and ``skipped`` notices, then
  each recording downloaded (``.mat``) and compared with the same run
  simulated offline (``simulate()``): missing samples and differing rows.

The peer is a plain ``websockets`` server broadcasting frames of the same size
and rate with ``broadcast()``, measured the same way in the same benchmark run.
"""

from __future__ import annotations

import io
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import scipy.io
import scipy.stats

from elab.api import convert
from elab.api import schemas as s
from elab.plants import get_plant
from elab.sim import Simulation
from tests.api.server import Server, free_port

ROOT = Path(__file__).resolve().parents[2]
FLEX = get_plant("flexible_link")
NAMES = ("r", "u", "theta", "alpha", "x_theta", "x_alpha", "x_theta_dot", "x_alpha_dot")
SETTLE = 3.0  # s after every watcher's hello (catching up from sample 0) before the window
RUN_SECONDS = 3600.0  # runs are stopped after the window; this only has to outlast it


@dataclass(frozen=True)
class Window:
    """A steady-state interval (wall clock, s) and the CPU each process spent in it (s)."""

    t0: float
    t1: float
    cpu: dict[str, float]
    slew: float = 0.0  # change of (wall clock − monotonic clock) over the window (s)

    @property
    def seconds(self) -> float:
        return self.t1 - self.t0


def cpu_seconds(pid: int) -> float:
    """utime + stime of process ``pid`` so far (s), all its threads."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def measure_window(pids: dict[str, int], seconds: float) -> Window:
    """Sleep ``SETTLE`` s, then sample each process's CPU over ``seconds`` s."""
    time.sleep(SETTLE)
    t0, c0 = time.time(), {name: cpu_seconds(pid) for name, pid in pids.items()}
    offset0 = time.time() - time.monotonic()  # both clocks are the host's, as the server's
    time.sleep(seconds)
    t1, c1 = time.time(), {name: cpu_seconds(pid) for name, pid in pids.items()}
    slew = time.time() - time.monotonic() - offset0
    return Window(t0, t1, {name: c1[name] - c0[name] for name in pids}, slew)


class Clients:
    """The client process (``tests.bench.wsload client``) watching ``urls``."""

    def __init__(self, urls: list[str], out: Path) -> None:
        self.out = out
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tests.bench.wsload", "client", "--out", str(out)],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert self.proc.stdin is not None
        self.proc.stdin.write("\n".join(urls) + "\n")
        self.proc.stdin.close()

    def wait_ready(self) -> None:
        """Blocks until every watcher has its hello."""
        assert self.proc.stdout is not None
        if not self.proc.stdout.readline():
            raise RuntimeError(f"client process exited ({self.proc.wait()}) before connecting")

    def result(self, timeout: float) -> dict[str, np.ndarray]:
        if self.proc.wait(timeout) != 0:
            raise RuntimeError(f"client process failed with exit code {self.proc.returncode}")
        with np.load(self.out) as npz:
            return dict(npz)


def watch(
    server_pids: dict[str, int],
    urls: list[str],
    seconds: float,
    tmp: Path,
    end: Callable[[], object] = lambda: None,
) -> tuple[Window, dict[str, np.ndarray]]:
    """Run the client process on ``urls``, measure a window, ``end()`` the runs; the window
    (the CPU of each server process, by name, and of the client) and what the watchers
    saw."""
    clients = Clients(urls, tmp / "frames.npz")
    try:
        clients.wait_ready()
        window = measure_window({**server_pids, "client": clients.proc.pid}, seconds)
        end()
        return window, clients.result(timeout=300)
    finally:
        if clients.proc.poll() is None:
            clients.proc.kill()
            clients.proc.wait()
        if clients.proc.stdout is not None:
            clients.proc.stdout.close()


def http(server: Server) -> httpx.Client:
    """A client for the API with a timeout long enough for a loaded server."""
    c = server.client()
    c.timeout = httpx.Timeout(300)
    return c


def start_runs(server: Server, n: int) -> list[dict[str, Any]]:
    body = {
        "plant": FLEX.id,
        "pace": "realtime",
        "Ts": FLEX.Ts,
        "duration": RUN_SECONDS,
        "controller": {"kind": "predefined"},
    }
    with http(server) as c:
        return [c.post("/runs", json=body).raise_for_status().json() for _ in range(n)]


def stop_runs(server: Server, runs: list[dict[str, Any]]) -> None:
    with http(server) as c:
        for run in runs:
            c.post(f"/runs/{run['id']}/stop").raise_for_status()


def check_recordings(server: Server, runs: list[dict[str, Any]]) -> dict[str, int]:
    """Download each (stopped) recording and compare it with the run simulated offline:
    samples stepped but not recorded, and recorded rows that differ."""
    sim = Simulation(convert.run_spec(s.RunCreate.model_validate(runs[0]["request"]), FLEX))
    want: np.ndarray | None = None
    out = {"recorded": 0, "missing": 0, "differing": 0, "not_stopped": 0}
    with http(server) as c:
        for run in runs:
            info = c.get(f"/runs/{run['id']}").raise_for_status().json()
            mat = scipy.io.loadmat(
                io.BytesIO(
                    c.get(f"/runs/{run['id']}/data", params={"format": "mat"})
                    .raise_for_status()
                    .content
                )
            )
            got = np.column_stack([mat[name].ravel() for name in NAMES])
            if want is None or want.shape[0] < got.shape[0]:
                res = sim.advance(got.shape[0] - (0 if want is None else want.shape[0]))
                part = np.column_stack([res.r, res.u, res.y, res.x])
                want = part if want is None else np.concatenate([want, part])
            out["recorded"] += got.shape[0]
            out["missing"] += info["n_samples"] - got.shape[0]
            out["differing"] += int(np.any(got != want[: got.shape[0]], axis=1).sum())
            out["not_stopped"] += info["status"] != "stopped"
    return out


def latency(frames: dict[str, np.ndarray], window: Window) -> tuple[np.ndarray, np.ndarray]:
    """(latency in s, watcher index) of every frame received in the window."""
    w, k, t = frames["frame_w"], frames["frame_k"], frames["frame_t"]
    sample_time = frames["run_started_at"][w] + k * frames["run_Ts"][w]
    inside = (t >= window.t0) & (t < window.t1)
    return (t - sample_time)[inside], w[inside]


DRIFT_BIN = 5.0  # s of run time per point of the latency floor


def drift(frames: dict[str, np.ndarray], window: Window) -> np.ndarray:
    """Per watcher: the slope of its latency floor (the minimum over each ``DRIFT_BIN``
    of run time) vs sample time (ms/min), by Theil–Sen. A clock that drifts moves every
    frame's latency, the floor included; load moves single frames. Over 1 s bins (50
    frames) a busy host's minute-to-minute swings still showed as ±2 ms/min in the
    plain ``broadcast()`` peer, which has no run clock at all."""
    lat, w = latency(frames, window)
    k = frames["frame_k"][(frames["frame_t"] >= window.t0) & (frames["frame_t"] < window.t1)]
    Ts = frames["run_Ts"][w]
    slopes = []
    for i in np.unique(w):
        sec = np.floor(k[w == i] * Ts[w == i] / DRIFT_BIN).astype(int)
        bins = np.unique(sec)
        if bins.size < 2:  # a window shorter than two bins of its run time: no slope
            continue
        low = np.array([lat[w == i][sec == b].min() for b in bins])
        # Theil–Sen (the median of pairwise slopes): a second of client-side stall
        # moves a least-squares line, not the median
        slopes.append(scipy.stats.theilslopes(low, bins * DRIFT_BIN)[0] * 60e3)
    return np.array(slopes)


def summarise(window: Window, frames: dict[str, np.ndarray]) -> dict[str, float]:
    """The window's figures; "server" is every process of the server (E-Lab: the web
    process and its engine; the peer: its one process)."""
    lat, _ = latency(frames, window)
    d = np.abs(drift(frames, window))
    msgs = lat.size
    server = sum(cpu for name, cpu in window.cpu.items() if name != "client")
    return {
        "window": window.seconds,
        "server_core": server / window.seconds,
        "web_core": window.cpu.get("web", server) / window.seconds,
        "engine_core": sum(c for n, c in window.cpu.items() if n.startswith("engine"))
        / window.seconds,
        "broker_core": window.cpu.get("broker", 0.0) / window.seconds,
        "client_core": window.cpu["client"] / window.seconds,
        "msg_rate": msgs / window.seconds,
        "us_per_msg": server / msgs * 1e6,
        "p50": np.percentile(lat, 50) * 1e3,
        "p99": np.percentile(lat, 99) * 1e3,
        "max": lat.max() * 1e3,
        "drift_median": float(np.median(d)) if d.size else math.nan,
        "drift_max": float(d.max()) if d.size else math.nan,
        "watchers": frames["missing"].size,
        "watch_missing": int(frames["missing"].sum()),
        "overlap": int(frames["overlap"].sum()),
        "skipped": int(frames["skipped"].sum()),
        "errors": int(frames["errors"].sum()),
        "short": int(((frames["next_k"] != frames["end_k"]) | (frames["errors"] > 0)).sum()),
    }


def lab_server(data: Path, runs: int, **env: str) -> Server:
    """A started ``elab serve`` that takes ``runs`` live hour-long runs from one client
    (its storage budget too: each reserves 259 MB); its runs are watched by spectators
    only, so their owner's absence must not pause them. ``env``: more settings (a broker)."""
    return Server(
        data,
        **env,
        ELAB_MAX_LIVE_RUNS=str(runs + 10),
        ELAB_MAX_LIVE_PER_IDENTITY=str(runs + 10),
        ELAB_MAX_STORAGE_PER_IDENTITY=str(1 << 50),
        ELAB_MAX_RUNS_PER_IDENTITY=str(10 * runs + 10),
        ELAB_OWNER_GRACE="86400",
        ELAB_OWNER_GONE="86400",
        # the watchers are one visitor (the client process sends no cookie)
        ELAB_MAX_STREAMS_PER_IDENTITY=str(10 * runs + 1000),
    ).start()


def bench_elab(
    runs: int, watchers: int, seconds: float, extra: dict[str, int] | None = None, **env: str
) -> dict[str, float]:
    """``runs`` real-time runs, each followed by ``watchers`` watchers from sample 0; a
    ``seconds`` window, then every run is stopped and its recording checked. ``extra``:
    more processes whose CPU counts as the server's (a broker); ``env``: more settings."""
    with tempfile.TemporaryDirectory() as tmp:
        server = lab_server(Path(tmp) / "data", runs, **env)
        assert server.proc is not None
        try:
            started = start_runs(server, runs)
            urls = [
                f"{server.ws_url}{r['stream_url']}?from_seq=0"
                for r in started
                for _ in range(watchers)
            ]
            status: dict[str, Any] = {}

            def end() -> None:  # the stepper's last minute (the window), then stop
                with http(server) as c:
                    status.update(c.get("/server").raise_for_status().json()["stepper"])
                stop_runs(server, started)

            pids = {"web": server.proc.pid, **(extra or {})}
            if server.on_broker:  # each engine of its own
                pids |= {f"engine-{i}": p.pid for i, p in enumerate(server.engines) if p}
            else:
                pids["engine"] = server.engine_pid
            window, frames = watch(pids, urls, seconds, Path(tmp), end)
            rec = check_recordings(server, started)
        finally:
            server.stop()
    # the runs' clocks against wall time: the stepper's lateness trend (against the
    # monotonic clock the runs are paced by) plus how the wall clock moved against it
    slew = window.slew * 1e3 / (window.seconds / 60)  # ms per minute
    return {
        **summarise(window, frames),
        **{f"rec_{k}": v for k, v in rec.items()},
        "late_p99": status["late_p99_ms"],
        "late_max": status["late_max_ms"],
        "stepper_drift": status["drift_ms_per_min"],
        "slew": slew,
        "clock_drift": status["drift_ms_per_min"] + slew,
    }


def bench_peer(clients: int, seconds: float) -> dict[str, float]:
    """The plain ``websockets`` ``broadcast()`` server, same frames and client process."""
    port = free_port()
    peer = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "tests.bench.wsload",
            "peer",
            "--port",
            str(port),
            "--clients",
            str(clients),
            "--duration",
            str(seconds + SETTLE + 2.0),
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert peer.stdout is not None
        peer.stdout.readline()  # listening
        with tempfile.TemporaryDirectory() as tmp:
            window, frames = watch(
                {"server": peer.pid}, [f"ws://127.0.0.1:{port}/"] * clients, seconds, Path(tmp)
            )
        peer.wait(timeout=60)
    finally:
        if peer.poll() is None:
            peer.kill()
            peer.wait()
        if peer.stdout is not None:
            peer.stdout.close()
    return summarise(window, frames)


def bench_server(n: int = 300, seconds: float = 60.0) -> dict[str, dict[str, float]]:
    """The issue's two scenarios and the peer; ``seconds``: each measurement window."""
    from tests.bench.run import bench_whole_run  # the host's speed today, for the record

    t = time.monotonic()
    out = {
        "runs": bench_elab(n, 1, seconds),
        "watchers": bench_elab(1, n, seconds),
        "peer": bench_peer(n, seconds / 2),
    }
    out["meta"] = {
        "n": n,
        "seconds": seconds,
        "wall": time.monotonic() - t,
        "sim_ns": bench_whole_run()["sim_ns"],
    }
    return out


def server_section(n: int = 300, seconds: float = 60.0) -> str:
    """The markdown section of docs/benchmarks.md."""
    r = bench_server(n, seconds)
    a, b, p = r["runs"], r["watchers"], r["peer"]

    def row(label: str, key: str, fmt: str, goal: str = "") -> str:
        return f"| {label} | {format(a[key], fmt)} | {format(b[key], fmt)} | {goal} |"

    rec = (
        f"{a['rec_missing']:.0f} missing, {a['rec_differing']:.0f} differing of "
        f"{a['rec_recorded']:,.0f} rows"
    )
    return f"""## Live server (issue 3)

A real `elab serve` (the uvicorn web process and its engine process) on loopback; the
clients are one separate asyncio
process (`tests/bench/wsload.py`) holding every websocket, each a minimal RFC 6455 client on
a bare asyncio protocol (the `websockets` clients cost the client process 0.8–1 core at
this rate and made it, not the server, the source of latency); 2 shared cores. Flexible link,
predefined controller, Ts = 1 ms, real time, 20 ms frames (50 per second per watcher).
After every watcher has caught up, a {seconds:.0f} s window measures: server CPU from
`/proc/<pid>/stat` (utime + stime, all threads, of both processes); latency = receipt time − wall time of the
frame's last sample (`started_at + k·Ts`); run clock drift = the trend of
how late the stepping thread's ticks began over the window (`GET /api/v1/server`; a sample is
computed at the first tick at or after its due time `t_origin + k·Ts` on the monotonic
clock) plus how far the wall clock moved against the monotonic clock; latency floor trend =
Theil–Sen slope of each watcher's minimum latency per {DRIFT_BIN:.0f} s of run time (the
end-to-end view: delivery and client included); completeness at every watcher; then every run is stopped,
downloaded (.mat) and compared row by row with the same run simulated offline.

| figure | {n} runs × 1 watcher | 1 run × {n} watchers | goal |
|---|---|---|---|
{row("server CPU, share of one core (web + engine process)", "server_core", ".2f", "≤ 1")}
{row("… of which the web process", "web_core", ".2f")}
{row("… of which the engine process", "engine_core", ".2f")}
{row("messages per second (all watchers)", "msg_rate", ",.0f")}
{row("server CPU per message (µs)", "us_per_msg", ".1f")}
{row("latency p50 (ms)", "p50", ".1f")}
{row("latency p99 (ms)", "p99", ".1f", "≤ 50")}
{row("latency max (ms)", "max", ".1f")}
{row("run clock drift against wall time (ms per minute)", "clock_drift", ".3f", "≤ 1")}
{row("… of which the stepper's lateness trend", "stepper_drift", ".3f")}
{row("… of which wall vs monotonic clock", "slew", ".3f")}
| stepper ticks late, p99 / max (ms) | {a["late_p99"]:.2f} / {a["late_max"]:.1f} | {b["late_p99"]:.2f} / {b["late_max"]:.1f} | |
{row("latency floor trend at the watchers, median (ms per minute)", "drift_median", ".2f")}
{row("latency floor trend, worst watcher (ms per minute)", "drift_max", ".2f")}
{row("samples missing at the watchers", "watch_missing", ".0f", "0")}
{row("skipped notices", "skipped", ".0f")}
{row("watchers that missed the end of their run, or got an error", "short", ".0f", "0")}
| recordings vs offline simulation | {rec} | — | 0 missing |

Peer, in the same benchmark run: a plain `websockets` server sending frames of the same
size and rate to {n} clients with `broadcast()` (each frame encoded once, no compression,
as `elab serve`):

| figure | `websockets.broadcast()` | E-Lab, 1 run × {n} watchers |
|---|---|---|
| server CPU per message | {p["us_per_msg"]:.1f} µs | {b["us_per_msg"]:.1f} µs |
| latency p99 (ms) | {p["p99"]:.1f} | {b["p99"]:.1f} |
| latency floor trend, median (ms per minute) | {p["drift_median"]:.2f} | {b["drift_median"]:.2f} |
| **ratio E-Lab / broadcast(), CPU per message** | | **{b["us_per_msg"] / p["us_per_msg"]:.2f}×** |

The latency floor's own noise shows in the peer (a plain timer loop, no run clock): about
{p["drift_median"]:.1f} ms per minute on this machine. The whole benchmark took
{r["meta"]["wall"]:.0f} s. The host's speed that hour, for comparing runs of this table:
`simulate()` took {r["meta"]["sim_ns"]:.0f} ns per step (the engine section's figure; the
notes below say what it was on other days).
"""
