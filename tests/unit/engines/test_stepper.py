"""The stepping thread: mixed plants, a failure that must not hang the others, and the run
state machine (every command decided in the thread, one at a time)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from elab.engines.base import Block, Changed
from elab.engines.stepper import Stepper
from elab.errors import Conflict
from elab.laws import StateFeedback
from elab.lifecycle import RunState
from elab.plants import get_plant
from elab.sim import RunSpec, Square, Step, compile_run, simulate


class Sink:
    def __init__(self) -> None:
        self.data: dict[str, list[np.ndarray]] = {}  # each run's samples, as they came
        self.ended: dict[str, Changed] = {}
        self.changes: list[Changed] = []

    def __call__(self, blocks: list[Block], changes: list[Changed]) -> None:
        for b in blocks:
            for run_id, rows in zip(b.run_ids, b.data, strict=True):
                self.data.setdefault(run_id, []).append(rows)
        self.changes += changes
        for c in changes:
            if not c.state.live:
                self.ended[c.run_id] = c

    def wait_ended(self, *ids: str, timeout: float = 30.0) -> None:
        assert _until(lambda: all(i in self.ended for i in ids), timeout), self.ended


def _until(cond: Callable[[], bool], timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.01)
    return False


@pytest.fixture
def sink_stepper() -> Iterator[tuple[Sink, Stepper]]:
    sink = Sink()
    stepper = Stepper(sink)
    stepper.start()
    yield sink, stepper
    stepper.close()


def spec(plant_id: str, duration: float = 2.0) -> RunSpec:
    p = get_plant(plant_id)
    return RunSpec(p, p.predefined, Step(0.1), duration=duration)


def test_runs_of_every_plant_joining_one_after_another_are_exact(
    sink_stepper: tuple[Sink, Stepper],
) -> None:
    sink, stepper = sink_stepper
    ids = ["flexible_link", "double_pendulum", "belt_conveyor"]
    for pid in ids:
        stepper.add(pid, compile_run(spec(pid)), "fast")
        assert _until(lambda pid=pid: pid in sink.data, 10)  # type: ignore[misc]
    sink.wait_ended(*ids)
    for pid in ids:
        assert sink.ended[pid].state == "finished"
        data = np.concatenate(sink.data[pid])
        alone = simulate(spec(pid))
        np.testing.assert_array_equal(data[:, 2 : 2 + alone.y.shape[1]], alone.y)


def test_a_failure_while_stepping_fails_the_live_runs_and_the_thread_goes_on(
    sink_stepper: tuple[Sink, Stepper], caplog: pytest.LogCaptureFixture
) -> None:
    sink, stepper = sink_stepper
    real = stepper._batch.advance
    calls = {"n": 0}

    def flaky(n: int, slots: list[int] | None = None) -> np.ndarray:
        calls["n"] += 1
        if calls["n"] == 3:
            raise RuntimeError("boom")
        return real(n, slots)

    stepper._batch.advance = flaky  # type: ignore[method-assign]
    stepper.add("a", compile_run(spec("flexible_link", 600.0)), "realtime")
    sink.wait_ended("a")
    assert sink.ended["a"].state == "failed"
    assert "boom" in (sink.ended["a"].error or "")
    assert "stepping failed" in caplog.text
    stepper.add("b", compile_run(spec("belt_conveyor")), "fast")  # still serving
    sink.wait_ended("b")
    assert sink.ended["b"].state == "finished"


def test_a_real_time_run_gets_whole_frames_at_ticks_never_before_they_are_due() -> None:
    """Sample 0 due one sample after a tick: each tick holds whole 20 ms frames (20 samples
    at 1 kHz) — no frame waits for the next tick — and no sample comes before it is due."""
    got: list[tuple[float, int, int]] = []  # (clock at delivery, k0, n)

    def sink(blocks: list[Block], ended: list[Changed]) -> None:
        got.extend((time.monotonic(), k0, b.data.shape[1]) for b in blocks for k0 in b.k0)

    stepper = Stepper(sink)
    run = compile_run(spec("flexible_link", 1.0))
    t_origin = stepper.origin(time.monotonic(), run.Ts)
    stepper.start()
    try:
        stepper.add("a", run, "realtime", t_origin=t_origin)
        assert _until(lambda: sum(n for _, _, n in got) >= 400, 10)
    finally:
        stepper.close()
    t, k0, n = (np.array(col) for col in zip(*got, strict=True))
    assert k0[0] == 0 and np.all(k0[1:] == np.cumsum(n)[:-1])  # consecutive
    assert np.all(k0 % 20 == 0) and np.all(n % 20 == 0), list(zip(k0, n, strict=True))[:5]
    due_last = t_origin + (k0 + n - 1) * run.Ts
    assert np.all(t >= due_last - 1e-6)  # never early


def test_a_long_fast_run_does_not_push_the_tick_grid_ahead_of_the_clock(
    sink_stepper: tuple[Sink, Stepper],
) -> None:
    """A fast run is stepped in passes 0.5 ms apart; each once moved the next tick's time
    on by a whole tick (20 ms), so after 600 s of fast run the thread slept about 12 s
    before its next tick, and every real-time run stood still meanwhile (an extreme-number
    hunt found it: "the engine's stepping thread is not ticking")."""
    sink, stepper = sink_stepper
    stepper.add("fast", compile_run(spec("flexible_link", 600.0)), "fast")
    sink.wait_ended("fast", timeout=120)
    run = compile_run(spec("flexible_link", 10.0))
    stepper.add("rt", run, "realtime")
    assert _until(lambda: sum(len(r) for r in sink.data.get("rt", [])) >= 100, 5.0)
    assert time.monotonic() - stepper.last_tick < 1.0


class _Broken:
    """A reference whose samples cannot be computed after the first block (as a PRBS
    held 10³⁰⁰ samples once could not)."""

    def sample(self, k0: int, n: int, Ts: float) -> np.ndarray:
        if k0 > 0:
            raise OverflowError("Python int too large to convert to C long")
        return np.full(n, 0.1)


def test_a_run_whose_signals_fail_ends_alone_and_the_others_go_on(
    sink_stepper: tuple[Sink, Stepper], caplog: pytest.LogCaptureFixture
) -> None:
    sink, stepper = sink_stepper
    p = get_plant("flexible_link")
    stepper.add("good", compile_run(spec("flexible_link", 5.0)), "fast")
    stepper.add("bad", compile_run(RunSpec(p, p.predefined, _Broken(), duration=5.0)), "fast")
    sink.wait_ended("good", "bad")
    assert sink.ended["bad"].state == "failed"
    assert "OverflowError" in (sink.ended["bad"].error or ""), sink.ended["bad"]
    assert sink.ended["good"].state == "finished"
    data = np.concatenate(sink.data["good"])
    np.testing.assert_array_equal(data[:, 2:3], simulate(spec("flexible_link", 5.0)).y[:, :1])
    assert "signals failed" in caplog.text


def test_timing_reports_how_late_ticks_began_and_the_trend_as_clock_drift() -> None:
    stepper = Stepper(lambda blocks, ended: None)  # not started: its record filled by hand
    assert stepper.timing()["drift_ms_per_min"] == 0.0  # nothing yet
    # a minute of ticks, each 0.2 ms + 0.5 ms per minute late, with jitter and, early on,
    # a stall of 200 ms
    t = np.arange(3000) * 0.02
    late = 0.2e-3 + 0.5e-3 * t / 60 + 1e-4 * (np.arange(3000) % 3 == 0)
    late[100:110] = 0.2
    for ti, lag in zip(t, late, strict=True):
        stepper.tick_log.add(ti, lag, lag)  # (a run's clock lags as late as its tick)
    timing = stepper.timing()
    assert timing["drift_ms_per_min"] == pytest.approx(0.5, rel=0.05)  # the stall: no tilt
    assert timing["window_s"] == pytest.approx(59.98)
    assert 0.2 < timing["late_p50_ms"] < 0.81 and timing["late_max_ms"] == pytest.approx(200)
    assert timing["tick_rate"] == pytest.approx(50, rel=1e-3)  # 1 / 20 ms, as planned
    assert timing["clock_lag_max_ms"] == pytest.approx(200)


def test_a_diverging_run_fails_at_its_divergence_and_its_neighbours_go_on(
    sink_stepper: tuple[Sink, Stepper],
) -> None:
    """Two runs of one plant stepped in one block, one of them unstable: that one ends
    `failed` with the samples before it diverged (those of the offline simulation), the
    other finishes complete and exact."""
    sink, stepper = sink_stepper
    flex = get_plant("flexible_link")
    bad = RunSpec(
        flex,
        StateFeedback((20, 20, 20, 20)),
        Square(math.radians(30), 4.0),
        duration=10.0,
        saturate=False,
    )
    good = spec("flexible_link", 10.0)
    stepper.add("bad", compile_run(bad), "fast")
    stepper.add("good", compile_run(good), "fast")
    sink.wait_ended("bad", "good")
    offline = simulate(bad)
    assert sink.ended["bad"].state == "failed" and "diverged" in (sink.ended["bad"].error or "")
    assert sink.ended["bad"].k == offline.n < 10_000
    data = np.concatenate(sink.data["bad"])
    np.testing.assert_array_equal(data[:, 1], offline.u)
    assert sink.ended["good"].state == "finished"
    data = np.concatenate(sink.data["good"])
    np.testing.assert_array_equal(data[:, 2 : 2 + flex.ny], simulate(good).y)


def test_of_simultaneous_commands_each_is_decided_once_in_order(
    sink_stepper: tuple[Sink, Stepper],
) -> None:
    """Five stops at once: exactly one stops the run, four get Conflict; a pause of a paused
    run, a resume of a running one and any command after the end get Conflict too."""
    sink, stepper = sink_stepper
    stepper.add("a", compile_run(spec("flexible_link", 600.0)), "realtime")
    assert stepper.control("a", "pause").result(5) >= 0
    with pytest.raises(Conflict, match="paused: cannot become paused"):
        stepper.control("a", "pause").result(5)
    stepper.control("a", "resume").result(5)
    with pytest.raises(Conflict, match="running: cannot become running"):
        stepper.control("a", "resume").result(5)
    stops = [stepper.control("a", "stop") for _ in range(5)]
    outcomes = [f.exception(5) for f in stops]
    assert sum(e is None for e in outcomes) == 1
    assert all(isinstance(e, Conflict) and "has ended" in str(e) for e in outcomes if e is not None)
    for action in ("pause", "resume", "stop"):
        with pytest.raises(Conflict, match="run a has ended"):
            stepper.control("a", action).result(5)
    assert [c.state for c in sink.changes if c.run_id == "a"] == [
        RunState.PAUSED,
        RunState.RUNNING,
        RunState.STOPPED,
    ]


def test_end_interrupts_the_given_live_runs_with_the_reason(
    sink_stepper: tuple[Sink, Stepper],
) -> None:
    sink, stepper = sink_stepper
    for run_id in ("a", "b", "c"):
        stepper.add(run_id, compile_run(spec("belt_conveyor", 600.0)), "realtime")
    assert stepper.end(["a", "nope"], RunState.FAILED, "disk full").result(5) == ["a"]
    assert sorted(stepper.end(None, RunState.INTERRUPTED, "shut down").result(5)) == ["b", "c"]
    assert (sink.ended["a"].state, sink.ended["a"].error) == (RunState.FAILED, "disk full")
    assert sink.ended["c"].state == RunState.INTERRUPTED and stepper.live_count == 0
