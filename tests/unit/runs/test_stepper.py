"""The stepping thread: mixed plants, and a failure that must not hang the others."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from elab.plants import get_plant
from elab.runs.stepper import Chunk, Ended, Stepper
from elab.sim import RunSpec, Step, compile_run, simulate


class Sink:
    def __init__(self) -> None:
        self.chunks: dict[str, list[Chunk]] = {}
        self.ended: dict[str, Ended] = {}

    def __call__(self, chunks: list[Chunk], ended: list[Ended]) -> None:
        for c in chunks:
            self.chunks.setdefault(c.run_id, []).append(c)
        for e in ended:
            self.ended[e.run_id] = e

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
        sink_stepper: tuple[Sink, Stepper]) -> None:
    sink, stepper = sink_stepper
    ids = ["flexible_link", "double_pendulum", "belt_conveyor"]
    for pid in ids:
        stepper.add(pid, compile_run(spec(pid)), "fast")
        assert _until(lambda pid=pid: pid in sink.chunks, 10)  # type: ignore[misc]
    sink.wait_ended(*ids)
    for pid in ids:
        assert sink.ended[pid].state == "finished"
        data = np.concatenate([c.data for c in sink.chunks[pid]])
        alone = simulate(spec(pid))
        np.testing.assert_array_equal(data[:, 2:2 + alone.y.shape[1]], alone.y)


def test_a_failure_while_stepping_fails_the_live_runs_and_the_thread_goes_on(
        sink_stepper: tuple[Sink, Stepper], caplog: pytest.LogCaptureFixture) -> None:
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
