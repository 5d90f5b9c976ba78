"""The rig engine's host loop against the emulated rig as a real process: a run recorded
like a simulation's and close to it, trips that stop the motor and say why, a rig that
dies mid-run, and laws the rig cannot run.

The emulator's watchdog is 200 samples here: this loop runs in the test process, which
is not real-time and is descheduled for tens of milliseconds beside two CPU hogs (the
engine process of a server is; tests/unit/rig/test_closed_loop.py says the same)."""

from __future__ import annotations

import math
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from elab.controllers.templates import python_source
from elab.engines.base import Block, Changed, Ended, Health, RunOrder
from elab.engines.rig import CHANNELS, RigEngine, RigSettings
from elab.errors import Conflict, InvalidInput, Unavailable
from elab.laws import CodeController, OpenLoop, StateFeedback
from elab.lifecycle import RunState
from elab.plants.flexible_link import PLANT
from elab.rig.driver import TcpDriver
from elab.rig.estop import estop_address, send_estop
from elab.rig.messages import Action
from elab.rig.supervisor import SafetyLimits
from elab.rig_queue import Arm, Join, Leave, Phase, Start
from elab.sim import RunSpec, Square, Step, simulate
from elab.sim.spec import compile_run
from elab.store.base import ParamChange, RunRecord
from elab.store.sqlite import SQLiteStore
from tests.unit.rig.emulator_process import Running, running_emulator


class Heard:
    """The engine's events, as the run manager would hear them."""

    def __init__(self) -> None:
        self.changes: list[Changed] = []
        self.ends: dict[str, Ended] = {}
        self.rows_of: dict[str, int] = {}
        self.cond = threading.Condition()

    def started(self, engine: str, record: RunRecord, order: object = None) -> None:
        pass

    def blocks(self, engine: str, blocks: list[Block]) -> None:
        for b in blocks:
            for run_id in b.run_ids:
                self.rows_of[run_id] = self.rows_of.get(run_id, 0) + b.data.shape[1]

    @property
    def rows(self) -> int:
        return sum(self.rows_of.values())

    def changed(self, engine: str, change: Changed) -> None:
        with self.cond:
            self.changes.append(change)
            self.cond.notify_all()

    def params(self, engine: str, run_id: str, change: ParamChange, new: object = None) -> None:
        pass

    def committed(self, engine: str, counts: dict[str, int]) -> None:
        pass

    def ended(self, engine: str, run_id: str, ended: Ended) -> None:
        with self.cond:
            self.ends[run_id] = ended
            self.cond.notify_all()

    def stored(self, engine: str, run_id: str) -> None:
        pass

    def health(self, engine: str, health: Health) -> None:
        pass

    def lost(self, engine: str, reason: str) -> None:
        pass

    def resync(self, engine: str) -> None:
        pass

    def wait_ended(self, run_id: str, timeout: float = 60.0) -> Ended:
        with self.cond:
            assert self.cond.wait_for(lambda: run_id in self.ends, timeout), self.changes
            return self.ends[run_id]


@pytest.fixture
def rig() -> Iterator[Running]:
    # the emulator's clock real-time, as a board's own (starved beside CPU hogs, it went
    # silent past the loop's 0.1 s)
    with running_emulator(
        "--rig-seed", "7", "--watchdog-samples", "200", "--realtime", "20"
    ) as running:
        yield running


def _engine(
    tmp_path: Path,
    rig: Running,
    heard: Heard,
    limits: SafetyLimits | None = None,
    **settings: Any,
) -> RigEngine:
    store = SQLiteStore(tmp_path / "elab.sqlite3")
    connect: Callable[[], TcpDriver] = rig.driver
    engine = RigEngine(
        "rig-0",
        store,
        heard,
        # the loop thread real-time where allowed (as in the rig engine process; refused
        # without CAP_SYS_NICE, with a warning in the log)
        RigSettings(address="", still_for=0.2, realtime=10, **settings),
        connect,
        limits,
    )
    engine.start()
    _until(lambda: engine.identity is not None, "the engine connects to the rig")
    return engine


def _until(ok: Callable[[], bool], what: str, timeout: float = 30.0) -> None:
    end = time.monotonic() + timeout
    while not ok():
        assert time.monotonic() < end, f"not within {timeout} s: {what}"
        time.sleep(0.01)


def _drive(engine: RigEngine, order: RunOrder, user: str = "a-student") -> RunRecord:
    """Add ``order`` as its driver would: in the rig's queue, armed, the run seated (after
    the last run the rig settles first), then the engine takes it."""
    # (still and zeroed first: after every run and when the rig connects, and again if
    # a loaded machine made the rig look silent and the engine reconnected meanwhile)
    _until(lambda: engine.ready() and _seat(engine, order.id, user), "the rig seats the run")
    added: list[RunRecord] = []

    def add() -> bool:
        try:
            added.append(engine.add(order))
        except Conflict as exc:
            if "settling" not in str(exc):
                raise
            return False
        return True

    _until(add, "the engine takes the run")
    return added[0]


def _seat(engine: RigEngine, run_id: str, user: str) -> bool:
    store, s, now = engine.store, engine.settings.seat, time.time()
    q = store.rig_queue(s.rig, s.policy, now)
    try:
        if q.place(user) is None:
            q = store.apply_rig(s.rig, Join(user), s.policy, now).queue
        if q.seat is not None and q.seat.phase is Phase.SEATED:
            q = store.apply_rig(s.rig, Arm(user), s.policy, now).queue
        store.apply_rig(s.rig, Start(user, run_id), s.policy, now)
    except Conflict:  # settling after the last run
        return False
    return True


def _order(run_id: str, spec: RunSpec) -> RunOrder:
    return RunOrder(run_id, spec, "realtime", "rig", "design", {"plant": "flexible_link"})


def _finished(
    engine: RigEngine,
    heard: Heard,
    run_id: str,
    spec: RunSpec,
    during: Callable[[str], None] | None = None,
) -> tuple[str, Ended]:
    """Run ``spec`` on the rig until it finishes (``during``: what the test does to the
    run once it is taken): this loop runs in the test process, not real-time, and a
    machine that starves it for a tenth of a second fails a run as a real rig would (the
    rig's watchdog, late answers that let the link swing past a trip). Such a run is
    tried again, up to three times; every failure is in the message when none finishes."""
    failures: list[str] = []
    for attempt in range(3):
        rid = run_id if attempt == 0 else f"{run_id}-again-{attempt}"
        _drive(engine, _order(rid, spec))
        if during is not None:
            during(rid)
        ended = heard.wait_ended(rid)
        if ended.state is not RunState.FAILED:
            return rid, ended
        failures.append(f"{rid} failed at sample {ended.n}: {ended.error}")
        _until(lambda: engine.settle is None, "the rig settles after a failed run")
    raise AssertionError("no run finished: " + "; ".join(failures))


SQUARE = RunSpec(PLANT, PLANT.predefined, Square(math.radians(20), 2.0), duration=2.0)
SQUARE_R = compile_run(SQUARE).exogenous(0, 2000)[:, 0]


def test_the_predefined_lqr_runs_on_the_rig_recorded_and_close_to_its_simulation(
    tmp_path: Path, rig: Running
) -> None:
    heard = Heard()
    engine = _engine(tmp_path, rig, heard)
    try:
        rid, ended = _finished(engine, heard, "r-1", SQUARE)
        record = engine.store.get_run(rid)
        assert record.channels == CHANNELS and record.n_planned == 2000
        assert (ended.state, ended.n) == (RunState.FINISHED, 2000), ended
        data = engine.store.read(rid, 0, 2000)
        assert heard.rows_of[rid] == 2000
        sim = simulate(SQUARE)
        theta_rig, theta_sim = data[:, 2], sim.y[:, 0]
        # the emulated rig differs from the model (its hidden parameters, friction, a dead
        # zone): the same law tracks the same square wave within 3° RMS of the simulation
        # (over the samples measured: a sample the rig dropped is NaN)
        rms = math.degrees(float(np.sqrt(np.nanmean((theta_rig - theta_sim) ** 2))))
        assert rms < 3.0, rms  # 2.0° measured quiet
        # and ends near the reference (−20° after the square's second half-period)
        assert abs(math.degrees(theta_rig[-1] - data[-1, 0])) < 4.0
        assert np.all(np.abs(data[:, 1]) <= 10.0)  # the supervisor's clip
        answered = data[np.isfinite(data[:, 6]), 6]
        assert answered.size > 1900 and np.all(answered < 0.5)  # latencies recorded, in s
    finally:
        engine.close()


def test_an_unstable_law_trips_the_angle_limit_and_the_motor_stops(
    tmp_path: Path, rig: Running
) -> None:
    heard = Heard()
    engine = _engine(tmp_path, rig, heard)
    try:
        # positive feedback on θ: a run-away whose voltage grows with θ (10 V only beyond
        # 120°), so the link bends little and the angle limit trips
        unstable = StateFeedback((-5.0, 0.0, 0.0, 0.0), "velocity_filters")
        spec = RunSpec(PLANT, unstable, Step(math.radians(30)), duration=10.0)
        _drive(engine, _order("r-2", spec))
        ended = heard.wait_ended("r-2")
        assert ended.state is RunState.FAILED
        assert ended.error is not None and "safety trip (angle)" in ended.error, ended.error
        data = engine.store.read("r-2", 0, ended.n)
        last = data[-10:, 2][np.isfinite(data[-10:, 2])]
        assert ended.n < 10_000 and np.all(np.abs(last) > math.radians(120))
        assert data[-1, 1] == 0.0  # the tripping sample was answered with 0 V
        _until(lambda: engine.store.get_run("r-2").status == "failed", "the end is stored")
        assert "angle" in (engine.store.get_run("r-2").error or "")
    finally:
        engine.close()


def test_a_rig_that_dies_mid_run_fails_the_run_and_keeps_its_samples(
    tmp_path: Path, rig: Running
) -> None:
    heard = Heard()
    engine = _engine(tmp_path, rig, heard)
    try:
        _drive(engine, _order("r-3", SQUARE))
        _until(lambda: heard.rows >= 200, "200 samples recorded")
        rig.proc.kill()
        ended = heard.wait_ended("r-3")
        assert ended.state is RunState.FAILED
        assert ended.error is not None and "rig" in ended.error
        assert 200 <= ended.n < 2000
        assert engine.store.read("r-3", 0, ended.n).shape == (ended.n, len(CHANNELS))
        _until(lambda: engine.identity is None, "the engine sees the rig gone")
        assert engine.health().timing["connected"] == 0
    finally:
        engine.close()


def test_one_run_at_a_time_and_only_laws_the_rig_can_run(tmp_path: Path, rig: Running) -> None:
    heard = Heard()
    engine = _engine(tmp_path, rig, heard)
    try:
        true_state = StateFeedback(PLANT.predefined.K, "true_state")
        with pytest.raises(InvalidInput, match=r"controller\.estimate"):
            _drive(engine, _order("r-4", RunSpec(PLANT, true_state, duration=1.0)))
        _drive(engine, _order("r-5", SQUARE))
        with pytest.raises(Conflict, match="one run at a time"):
            engine.add(_order("r-6", SQUARE))
        k = engine.control("r-5", "stop", "stopped by its owner").result(timeout=10)
        ended = heard.wait_ended("r-5")
        assert (ended.state, ended.n) == (RunState.STOPPED, k)
        with pytest.raises(Conflict, match="cannot pause"):
            engine.control("r-5", "pause").result(timeout=10)
        # after a run the rig settles (0 V until still) and re-zeroes before the next
        _until(lambda: engine.settle is None, "the rig settles and re-zeroes")
        assert _finished(engine, heard, "r-7", SQUARE)[1].state is RunState.FINISHED
    finally:
        engine.close()


def test_an_identification_runs_excitation_reaches_the_motor(tmp_path: Path, rig: Running) -> None:
    heard = Heard()
    engine = _engine(tmp_path, rig, heard)
    try:
        # open loop, the excitation at the plant input: u is the excitation itself (its
        # steps of 0.8 V are within the supervisor's slew limit of 1 V per sample); the
        # simulated sensor noise a run may ask for is not added to a real rig's sensors
        spec = RunSpec(
            PLANT,
            OpenLoop(),
            Step(0.0),
            duration=1.0,
            excitation=Square(0.4, 0.2),
            excitation_at="input",
            noise_seed=3,
        )
        rid, ended = _finished(engine, heard, "r-8", spec)
        assert (ended.state, ended.n) == (RunState.FINISHED, 1000), ended
        data = engine.store.read(rid, 0, 1000)
        expected = compile_run(spec).exogenous(0, 1000)[:, 1]
        np.testing.assert_allclose(data[:, 1], expected, rtol=0, atol=1e-12)
    finally:
        engine.close()


class StoppingDriver(TcpDriver):
    """A driver that, when told to, answers one sample with STOP instead of a voltage (as
    an amplifier that tripped between runs leaves the motor off)."""

    stop_once = False

    def write(self, seq: int, u: float) -> None:
        if self.stop_once:
            self.stop_once = False
            self.command(Action.STOP)
            return
        super().write(seq, u)


def test_a_motor_switched_off_between_runs_is_enabled_before_the_next(
    tmp_path: Path, rig: Running
) -> None:
    heard = Heard()
    driver = StoppingDriver(rig.host, rig.port)
    store = SQLiteStore(tmp_path / "elab.sqlite3")
    # the loop real-time as in _engine (this test had an ordinary thread: starved beside
    # the browser tests, its late answers let α pass the rig's 15° trip in 2 of 5 runs)
    engine = RigEngine(
        "rig-0", store, heard, RigSettings(still_for=0.2, realtime=10), lambda: driver
    )
    engine.start()
    try:
        _until(lambda: engine.identity is not None, "the engine connects to the rig")
        driver.stop_once = True
        _until(lambda: not driver.stop_once, "the rig told to stop its motor")
        # a 10° step: what matters is that the motor drives; a 20° one peaked α near the
        # rig's 15° safety trip, which late answers beside the suite passed once
        spec = RunSpec(PLANT, PLANT.predefined, Step(math.radians(10)), duration=1.5)
        rid, ended = _finished(engine, heard, "r-9", spec)
        assert ended.state is RunState.FINISHED, ended
        theta = engine.store.read(rid, 0, 1500)[:, 2]
        # driven (not a motor left off, θ near 0): the step is tracked within 4°
        assert abs(math.degrees(theta[-1]) - 10.0) < 4.0
    finally:
        engine.close()


def test_a_reference_that_overflows_the_law_ends_the_run_at_0_v(
    tmp_path: Path, rig: Running
) -> None:
    heard = Heard()
    engine = _engine(tmp_path, rig, heard)
    try:
        # gains of 1e300 on a reference of 1e9 (the largest a signal may be): K r overflows
        huge = StateFeedback(tuple(1e300 for _ in PLANT.states), "velocity_filters")
        spec = RunSpec(PLANT, huge, Step(1e9), duration=3.0)
        _drive(engine, _order("r-10", spec))
        ended = heard.wait_ended("r-10")
        assert ended.state is RunState.FAILED, ended
        assert ended.error is not None and "overflow" in ended.error, ended.error
        assert engine.store.read("r-10", 0, ended.n)[-1, 1] == 0.0
    finally:
        engine.close()


def test_a_python_controller_drives_the_rig_like_its_declarative_twin(
    tmp_path: Path, rig: Running
) -> None:
    heard = Heard()
    # late answers held rather than tripping, and 0.9 ms to answer: this test's machine
    # may be loaded (the next test shows the trip; test_rig_law.py the same voltages)
    engine = _engine(tmp_path, rig, heard, SafetyLimits(n_late=1000), code_deadline=0.9e-3)
    try:
        code = CodeController(python_source(PLANT, PLANT.predefined), "lqr.py")
        # a 10° step: a 20° one tripped α's 15° limit once in a loaded run (late answers
        # held the last voltage for a while; the same change as the declarative test's)
        spec = RunSpec(PLANT, code, Step(math.radians(10)), duration=2.0)
        _drive(engine, _order("r-11", spec))
        ended = heard.wait_ended("r-11")
        assert (ended.state, ended.n) == (RunState.FINISHED, 2000), ended.error
        theta = engine.store.read("r-11", 0, 2000)[:, 2]
        # tracked as the LQR does (a sample the rig dropped is NaN in the recording)
        assert abs(math.degrees(np.nanmean(theta[-200:])) - 10.0) < 2.0
    finally:
        engine.close()


LOOPS_FOREVER = """
class Controller:
    def reset(self, params):
        self.k = 0

    def step(self, t, y, r):
        self.k += 1
        while self.k > 300:
            pass
        return 0.5
"""


def test_a_python_controller_that_loops_forever_trips_the_deadline_at_0_v(
    tmp_path: Path, rig: Running
) -> None:
    """The supervisor, not the student's process, is real-time: late answers hold the last
    voltage, ``n_late`` in a row trip the run, and the rig ends at 0 V."""
    heard = Heard()
    engine = _engine(tmp_path, rig, heard)
    try:
        spec = RunSpec(PLANT, CodeController(LOOPS_FOREVER, "loops.py"), duration=5.0)
        _drive(engine, _order("r-12", spec))
        ended = heard.wait_ended("r-12")
        assert ended.state is RunState.FAILED, ended
        assert ended.error is not None and "safety trip (deadline)" in ended.error, ended.error
        rows = engine.store.read("r-12", 0, ended.n)
        u = rows[:, 1]
        # the trip within n_late samples of the loop (earlier on a loaded machine, whose
        # late answers trip the same way); the controller counts its own steps, and a
        # sample the rig dropped (kept in its place, θ NaN) is never asked of it
        dropped = int(np.isnan(rows[:, 2]).sum())
        assert ended.n <= 300 + 5 + 1 + dropped and u[-1] == 0.0, (ended.n, dropped)
    finally:
        engine.close()


def test_an_emergency_stop_on_its_own_socket_ends_the_run_at_the_next_sample(
    tmp_path: Path, rig: Running
) -> None:
    heard = Heard()
    address = estop_address(tmp_path)
    engine = _engine(tmp_path, rig, heard, estop=address)
    try:
        _drive(engine, _order("r-13", SQUARE))
        _until(lambda: engine.current_run() == "r-13" and engine._active is not None, "running")
        send_estop(address, "a tester")
        ended = heard.wait_ended("r-13")
        assert ended.state is RunState.STOPPED and ended.n < 2000, ended
        assert ended.error is not None and "emergency stop by a tester" in ended.error
        # the queue hears it: the seat is the driver's again, the rig settles first
        s = engine.settings.seat
        _until(
            lambda: engine.store.rig_queue(s.rig, s.policy, time.time()).running is None,
            "the queue ends the run",
        )
    finally:
        engine.close()
    with pytest.raises(Unavailable, match="no rig engine listens"):
        send_estop(address, "too late")


def test_the_engine_stops_a_run_whose_driver_left_the_queue(tmp_path: Path, rig: Running) -> None:
    heard = Heard()
    engine = _engine(tmp_path, rig, heard)
    try:
        _drive(engine, _order("r-14", SQUARE), user="a-leaver")
        s = engine.settings.seat
        engine.store.apply_rig(s.rig, Leave("a-leaver"), s.policy, time.time())
        ended = heard.wait_ended("r-14")
        assert ended.state is RunState.STOPPED and ended.n < 2000, ended
        assert ended.error is not None and "slot" in ended.error, ended.error
    finally:
        engine.close()


def test_samples_the_rig_skipped_keep_their_place_on_its_clock(
    tmp_path: Path, rig: Running
) -> None:
    """The emulator stopped for 60 ms mid-run falls behind its clock: it integrates the
    periods it missed and sends only the newest sample (a gap in the sequence numbers).
    The recording keeps sample k at t = k·Ts: a row for each skipped sample with its
    reference and the voltage the amplifier held, NaN for what nobody measured."""
    heard = Heard()
    engine = _engine(tmp_path, rig, heard)
    try:

        def stop_the_rig_for_60_ms(rid: str) -> None:
            _until(
                lambda: engine.store.get_run(rid).n_stored > 500 or rid in heard.ends,
                "the run goes",
            )
            if rid not in heard.ends:  # (a starved run may have failed already: tried again)
                os.kill(rig.proc.pid, signal.SIGSTOP)
                time.sleep(0.06)
                os.kill(rig.proc.pid, signal.SIGCONT)

        rid, ended = _finished(engine, heard, "r-gap", SQUARE, stop_the_rig_for_60_ms)
        assert (ended.state, ended.n) == (RunState.FINISHED, 2000), ended
        data = engine.store.read(rid, 0, 2000)
        lost = np.flatnonzero(np.isnan(data[:, 2]))
        assert 40 <= lost.size <= 200, lost.size  # about 60 (a loaded machine adds some)
        assert np.all(np.isnan(data[lost, 3])) and np.all(np.isfinite(data[lost, :2]))
        # the reference of every row is the one at its time on the rig's clock
        assert np.array_equal(data[:, 0], SQUARE_R[:2000])
        # held: the voltage of each skipped row is the one before it
        first = lost[0]
        assert data[first, 1] == data[first - 1, 1]
    finally:
        engine.close()
