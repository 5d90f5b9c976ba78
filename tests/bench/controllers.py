"""Python controllers in the sandbox (issue 14): the seed's LQR as code against the same
LQR declarative in the same run, per step, and how many real-time code-controller runs
one core holds with the stepping thread's p99 tick lateness within 5 ms."""

from __future__ import annotations

import contextlib
import math
import os
import time

import numpy as np

from elab.controllers.templates import python_source
from elab.engines.base import Changed
from elab.engines.coded import CodedRun
from elab.engines.settings import CodeSettings
from elab.engines.stepper import Stepper
from elab.laws import CodeController, StateFeedback
from elab.lifecycle import RunState
from elab.plants import get_plant
from elab.sim import RunSpec, Simulation, Square, compile_run

FLEX = get_plant("flexible_link")
LQR = StateFeedback((20.0, -93.5614, 3.3621, 0.9623), "velocity_filters")
SIGNAL = Square(math.radians(30), 4.0)
CODE = CodeController(python_source(FLEX, LQR), "lqr.py")
TRIVIAL = CodeController("class Controller:\n    def step(self, t, y, r):\n        return 0.0\n")
LAG = 20.0  # ms: how far a run's clock may fall behind the wall clock (one tick)


def per_step() -> dict[str, float]:
    """A 10 s, 1 kHz run stepped through (started before the clock starts: the compiled
    run, the controller's process), code and declarative, in the same process."""
    Simulation(RunSpec(FLEX, LQR, SIGNAL, duration=0.01)).advance(10)  # loads the loop
    sim = Simulation(RunSpec(FLEX, LQR, SIGNAL, duration=10.0))
    t0 = time.perf_counter()
    sim.advance(10**6)
    out = {"declarative_us": (time.perf_counter() - t0) / 10_000 * 1e6}
    for name, law in (("lqr", CODE), ("trivial", TRIVIAL)):
        coded = CodedRun(compile_run(RunSpec(FLEX, law, SIGNAL, duration=10.0)), CodeSettings())
        try:
            t0 = time.perf_counter()
            for _ in range(10):
                _, failed = coded.advance(1000)
                assert failed is None, failed
            wall = time.perf_counter() - t0
            t = coded.times()
        finally:
            coded.close()
        out[f"{name}_wall_us"] = wall / 10_000 * 1e6
        out[f"{name}_compute_median_us"] = float(t["median_us"])
        out[f"{name}_compute_p99_us"] = float(t["p99_us"])
        out[f"{name}_trip_median_us"] = float(t["round_trip_median_us"])
        out[f"{name}_trip_p99_us"] = float(t["round_trip_p99_us"])
        out[f"{name}_misses"] = float(t["misses"])
    return out


def _load(n: int, seconds: float) -> dict[str, float]:
    """``n`` real-time code runs (the LQR) stepped as the engine steps them, each by a
    stepper thread of its own under ordinary scheduling (``SimulationEngine.add``), for
    ``seconds`` after their start: how far the runs' clocks fell behind the wall clock,
    the ticks each thread kept, and the runs that failed."""
    failed: list[str] = []

    def on_tick(blocks: object, changes: list[Changed]) -> None:
        failed.extend(c.error or "" for c in changes if c.state is RunState.FAILED)

    steppers: list[Stepper] = []
    try:
        for i in range(n):
            run = compile_run(RunSpec(FLEX, CODE, SIGNAL, duration=seconds + 30))
            coded = CodedRun(run)  # its controller started first: a lone stepper ends
            stepper = Stepper(on_tick, lone=True, ordinary=True)  # when it has no run
            stepper.start()
            steppers.append(stepper)
            stepper.add(f"r{i}", run, "realtime", coded=coded)
        time.sleep(2.0)  # their controllers started
        since = time.monotonic()
        time.sleep(seconds)
        ticks = [st.tick_log.entries() for st in steppers]
    finally:
        for stepper in steppers:
            with contextlib.suppress(Exception):  # a lone stepper whose run failed is gone
                stepper.end(None, RunState.INTERRUPTED, "benchmark over").result(timeout=30)
            stepper.close()
    window = [t[t[:, 0] >= since] for t in ticks]
    lag = [float(w[:, 2].max()) * 1e3 if w.size else math.inf for w in window]
    return {
        "lag_max_ms": max(lag),
        "lag_median_ms": float(np.median(lag)),
        "ticks_per_s": min(w.shape[0] for w in window) / seconds,
        "failed": float(len(failed)),
    }


def per_core(seconds: float = 8.0) -> list[tuple[int, dict[str, float]]]:
    """Runs at once on one core (this process and every controller process pinned to
    CPU 0), doubling until a run's clock falls more than :data:`LAG` behind."""
    cpus = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cpus)})
    levels: list[tuple[int, dict[str, float]]] = []
    try:
        for n in (1, 2, 4, 6, 8, 12, 16, 24, 32, 48):
            r = _load(n, seconds)
            levels.append((n, r))
            if not _held(r):
                break
    finally:
        os.sched_setaffinity(0, cpus)
    return levels


def _held(r: dict[str, float]) -> bool:
    return r["lag_max_ms"] <= LAG and not r["failed"]


def bench_controllers() -> str:
    s = per_step()
    levels = per_core()
    held = max((n for n, r in levels if _held(r)), default=0)
    overhead = s["lqr_trip_median_us"] - s["lqr_compute_median_us"]
    overhead99 = s["lqr_trip_p99_us"] - s["lqr_compute_p99_us"]
    rows = "\n".join(
        f"| {n} | {r['lag_median_ms']:.1f} | {r['lag_max_ms']:.1f} | "
        f"{r['ticks_per_s']:.1f} | {int(r['failed'])} |"
        for n, r in levels
    )
    return f"""## Python controllers in the sandbox (issue 14)

### Per step: the seed's LQR as Python code against the same LQR declarative, 10 s at 1 kHz

The code runs in its sandboxed process (bubblewrap, seccomp, rlimits) and answers each
step over a pipe; the declarative law is stepped by the compiled batch loop. The
controller's own compute time is its CPU time around `step`, inside its process; the round
trip is what the run waits for (request written to answer read). The sandbox's overhead
per step is the round trip less the compute time.

| | median | p99 |
|---|---|---|
| declarative LQR, the batch loop per sample (the peer) | {s["declarative_us"]:.2f} µs | |
| LQR as code: its compute time (numpy, inside the sandbox) | {s["lqr_compute_median_us"]:.1f} µs | {s["lqr_compute_p99_us"]:.1f} µs |
| LQR as code: round trip | {s["lqr_trip_median_us"]:.1f} µs | {s["lqr_trip_p99_us"]:.1f} µs |
| **sandbox overhead per step** (goal ≤ 15 µs median, ≤ 50 µs p99) | **{overhead:.1f} µs** | **{overhead99:.1f} µs** |
| a controller returning 0: round trip | {s["trivial_trip_median_us"]:.1f} µs | {s["trivial_trip_p99_us"]:.1f} µs |
| whole run per sample, LQR as code (wall; {int(s["lqr_misses"])} answers after 0.5 ms) | {s["lqr_wall_us"]:.1f} µs | |
| **ratio code / declarative, whole run** | **{s["lqr_wall_us"] / s["declarative_us"]:.0f}×** | |

Stepping a Python controller costs tens of microseconds per sample where the batch loop
costs a fraction of one: fine for one run at 1 kHz (a few percent of a core), and why
code runs are stepped outside the batch and limited per engine.

### Real-time code-controller runs one core holds

Every run steps the LQR as code at 1 kHz in real time, as the engine steps it: by a
stepper thread of its own under ordinary scheduling (a slow controller holds back its own
run only), its controller in its sandboxed process. This process and every controller
process are pinned to one CPU; over {8:g} s after the runs started, how far each run's
clock fell behind the wall clock (measured at every tick of its thread) and the ticks
the slowest thread kept (50 a second planned), doubling the runs until a clock falls more
than {LAG:g} ms (a tick) behind.

| runs | clock lag, median of the runs' largest (ms) | the largest (ms) | ticks a second, slowest thread | runs failed |
|---|---|---|---|---|
{rows}

**One core holds {held} real-time Python-controller runs** with every run's clock within
{LAG:g} ms of the wall clock and none failing. A simulation waits for a late answer
(docs/controllers.md), so a busy core makes the runs lag rather than changing their
samples. `ELAB_MAX_CODE_RUNS` (8 by default) bounds an engine's code runs.
"""
