"""The rig's host loop: one thread, paced by the rig's samples, that answers each with
the voltage of the run on the rig (:class:`HostLoop`; the engine's commands around it are
:class:`~elab.engines.rig.RigEngine`'s).

Per sample: the controller (:mod:`elab.engines.riglaw`) on the measured θ and α, the
trusted :class:`~elab.rig.supervisor.Supervisor` between it and the amplifier, the row
to the recorder and the watchers; between runs 0 V, and after one the settle (still, then
re-zeroed). A pending e-stop disables the amplifier at the next sample. Nothing here
writes to the store or waits on anything but the rig (the recorder writes in its own
thread), so the answer goes out within microseconds of the sample's arrival.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from elab.controllers.sandbox import ControllerFailed
from elab.engines.base import (
    Block,
    Changed,
    EngineEvents,
)
from elab.engines.recorder import Recorder
from elab.engines.riglaw import (
    Differentiator,
    Latency,
    RigLaw,
    tripped,
)
from elab.engines.settings import RigSettings
from elab.engines.ticks import realtime_thread
from elab.errors import Conflict, ElabError
from elab.lifecycle import RunState
from elab.rig.driver import Driver, RigDisconnected, RigSample, RigTimeout
from elab.rig.messages import Action as RigAction
from elab.rig.messages import RigIdentity, Status
from elab.rig.settle import (
    Settle,
    SettleLimits,
    SettlePhase,
    begin_settle,
    rezeroed,
    settle_step,
)
from elab.rig.supervisor import SafetyLimits, Supervisor
from elab.sim.spec import CompiledRun
from elab.store.base import RunRecord, RunStore

EXO_BLOCK = 1000  # samples of reference and excitation computed at once
ENABLE_EVERY = 50  # samples between two requests to enable a disabled amplifier
ENABLE_PATIENCE = 1000  # samples a new run waits for the amplifier before it fails
MAX_GAP = 1000  # samples: a longer gap in the sequence numbers is a restart, not a loss

log = logging.getLogger(__name__)

Array = NDArray[np.float64]
#: The recorded columns of a rig run: what the sensors measured and what the loop did.
CHANNELS = (
    ("r", "rad"),
    ("u", "V"),
    ("theta", "rad"),
    ("alpha", "rad"),
    ("theta_dot", "rad/s"),
    ("alpha_dot", "rad/s"),
    ("latency", "s"),
)


@dataclass
class ActiveRun:
    """The run the loop steps now: its controller as the loop steps it (``law``), the
    rows not yet handed on (from sample ``k0``), its reference and excitation for samples
    ``exo_k0 ..`` (``exo``: rows ``[r, e, …]``), and whether it was asked to end."""

    record: RunRecord
    law: RigLaw
    supervisor: Supervisor
    k: int = 0
    rows: list[list[float]] | None = None
    k0: int = 0
    exo: Array | None = None
    exo_k0: int = 0
    stop: tuple[RunState, str | None, Future[int] | None] | None = None
    u: float = 0.0  # V, the last voltage applied: what the amplifier holds through a gap
    dropped: int = 0  # samples the rig did not send (gaps in its sequence numbers)

    @property
    def run(self) -> CompiledRun:
        return self.law.run

    def exogenous(self, k: int) -> tuple[float, float]:
        """The reference and the input excitation at sample ``k`` (V)."""
        if self.exo is None or not self.exo_k0 <= k < self.exo_k0 + self.exo.shape[0]:
            n = min(EXO_BLOCK, self.run.n_samples - k)
            self.exo, self.exo_k0 = self.run.exogenous(k, max(n, 1)), k
        row = self.exo[k - self.exo_k0]
        return float(row[0]), float(row[1])


class HostLoop:
    """The loop thread and what it shares with the engine's commands (under ``_lock``):
    the run it steps (``_active``), the one starting at the next sample (``_pending``),
    changes to apply (``_swaps``), the e-stop (``_estop``), the settle after a run."""

    def __init__(
        self,
        engine_id: str,
        store: RunStore,
        events: EngineEvents,
        settings: RigSettings,
        connect: Callable[[], Driver],
        limits: SafetyLimits | None,
        recorder: Recorder,
    ) -> None:
        self.id = engine_id
        self.store = store
        self.settings = settings
        self.limits = limits or SafetyLimits()
        self._events = events
        self._connect = connect
        self.recorder = recorder
        self._lock = threading.Lock()
        self._active: ActiveRun | None = None
        self._pending: ActiveRun | None = None  # added, starting at the next sample
        self._reserved = False  # a run is being stored, outside the lock
        self._swaps: list[tuple[CompiledRun, Future[int]]] = []  # changes, in order
        self._closing = threading.Event()
        self._driver: Driver | None = None
        self._thread = threading.Thread(target=self._loop, name="elab-rig-loop", daemon=True)
        self.identity: RigIdentity | None = None
        self.problem: str | None = "not connected yet"
        self.last_sample = 0.0  # monotonic s
        self._latency = Latency()
        self._disabled = 0  # samples in a row the amplifier was off between runs
        self.settle_limits = SettleLimits(still_for=settings.still_for)
        self.settle: Settle | None = None  # after a run, until the rig is ready again
        self._t = 0.0  # s, the rig's clock: samples since connecting times Ts
        self._seq: int | None = None  # the last sample's sequence number
        self._theta_dot = Differentiator(settings.omega_c)
        self._alpha_dot = Differentiator(settings.omega_c)
        self._taking: str | None = None  # the run being added
        self._ended: list[str] = []  # runs ended, not yet told to the queue
        self._ended_lock = threading.Lock()
        self._estop: str | None = None  # who pressed the e-stop, until the loop acts

    # -- the loop --------------------------------------------------------------------
    def _loop(self) -> None:
        if self.settings.realtime > 0:  # answered ahead of every ordinary thread
            realtime_thread(self.settings.realtime)
        driver: Driver | None = None
        while not self._closing.is_set():
            self._driver = driver
            if driver is None:
                driver = self._link()
                if driver is None:
                    self._closing.wait(1.0)
                    continue
            try:
                sample = driver.read(self.settings.sample_timeout)
            except (RigTimeout, RigDisconnected, ElabError, OSError) as exc:
                self._lost(f"the rig went silent or away: {exc}")
                driver.close()
                driver = None
                continue
            self.last_sample = time.monotonic()
            u = self._sample(sample)
            try:
                driver.write(sample.seq, u)
            except (RigDisconnected, OSError) as exc:
                self._lost(f"the rig's connection was lost: {exc}")
                driver.close()
                driver = None
                continue
            self._latency.add(time.monotonic_ns() - sample.received_ns)
        if driver is not None:
            driver.close()

    def _link(self) -> Driver | None:
        try:
            driver = self._connect()
            self.identity = driver.connect()
            driver.command(RigAction.ENABLE)
        except (ElabError, OSError) as exc:
            self.identity, self.problem = None, str(exc)
            return None
        self.problem = None
        self._seq = None
        with self._lock:  # still and zeroed before its first run, as after every run
            self.settle = begin_settle(self._t)
        log.warning(
            "rig %s connected (firmware %s%s)",
            self.identity.rig_id,
            self.identity.firmware,
            ", emulated" if self.identity.emulated else "",
        )
        return driver

    def _lost(self, reason: str) -> None:
        self.identity, self.problem = None, reason
        with self._lock:
            active, self._active = self._active, None
        if active is not None:
            self._flush(active)
            self._end(active, RunState.FAILED, f"{reason}; the recording keeps what came before")

    def _sample(self, s: RigSample) -> float:
        """The voltage that answers sample ``s``."""
        Ts = self.identity.Ts if self.identity is not None else 1e-3
        gap = self._gap(s.seq)
        theta_dot = self._theta_dot.next(s.theta, Ts * (gap + 1))
        alpha_dot = self._alpha_dot.next(s.alpha, Ts * (gap + 1))
        enabled = s.status & Status.MOTOR_ENABLED and not s.status & Status.WATCHDOG_TRIPPED
        with self._lock:
            waiting = self._pending
            if waiting is not None and waiting.stop is not None:  # stopped before it began
                self._pending = None
                self._end(waiting, waiting.stop[0], waiting.stop[1])
                if waiting.stop[2] is not None:
                    waiting.stop[2].set_result(0)
            if self._estop is not None:
                self._emergency(self._estop)
            if self._active is None and self._pending is not None and enabled:
                self._active, self._pending = self._pending, None
                self._theta_dot.reset(s.theta)
                self._alpha_dot.reset(s.alpha)
                theta_dot = alpha_dot = 0.0
                gap = 0  # a gap before a run's first sample is not the run's
            active, swaps, self._swaps = self._active, self._swaps, []
        self._t += Ts * (gap + 1)
        if enabled:
            self._disabled = 0
        for run, applied in swaps:
            if active is None:
                applied.set_exception(Conflict("the run ended before its change"))
                continue
            active.law = active.law.changed(run)  # the controller's state goes on
            active.exo = None
            active.supervisor.touch(active.k * run.Ts)
            applied.set_result(active.k)
        if active is None:
            if not enabled and self._pending is not None:
                self._enable()
            return self._settling(theta_dot, alpha_dot)
        if active.stop is not None:
            state, reason, fut = active.stop
            self._finish(active, state, reason)
            if fut is not None:
                fut.set_result(active.k)
            return 0.0
        if gap:
            self._dropped(active, gap)
            if active.k >= active.run.n_samples:
                self._finish(active, RunState.FINISHED, None)
                return 0.0
        run, k = active.run, active.k
        t = k * run.Ts
        r, e = active.exogenous(k)
        try:
            u_req, late = active.law.u(t, r, e, s.theta, s.alpha)
        except ControllerFailed as exc:
            self._row(active, [r, 0.0, s.theta, s.alpha, theta_dot, alpha_dot, 0.0])
            active.k += 1
            self._finish(active, RunState.FAILED, f"{exc}; the motor at 0 V from then on")
            return 0.0
        if not math.isfinite(u_req):  # the law's arithmetic overflowed: nothing to apply
            self._row(active, [r, 0.0, s.theta, s.alpha, theta_dot, alpha_dot, 0.0])
            active.k += 1
            reason = (
                f"the controller's voltage is {u_req} at t = {t:.4g} s: its numbers overflow "
                "(a reference or gain too large); the motor at 0 V from then on"
            )
            self._finish(active, RunState.FAILED, reason)
            return 0.0
        fault = bool(s.status & Status.WATCHDOG_TRIPPED)
        decision = active.supervisor.step(
            k, t, s.theta, s.alpha, theta_dot, u_req, late, fault=fault
        )
        u = decision.u_applied
        latency = (time.monotonic_ns() - s.received_ns) * 1e-9
        self._row(active, [r, u, s.theta, s.alpha, theta_dot, alpha_dot, latency])
        active.k += 1
        active.u = u
        if decision.trip is not None:
            self._finish(active, RunState.FAILED, tripped(decision.trip))
            return 0.0
        if active.k >= run.n_samples:
            self._finish(active, RunState.FINISHED, None)
        return u

    def _enable(self) -> None:
        """The amplifier is off (a tripped watchdog, a STOP): ask the rig to enable it, at
        most every :data:`ENABLE_EVERY` samples; a new run waits for it (and fails if it
        never comes, see :meth:`_overdue`)."""
        self._disabled += 1
        if self._driver is not None and self._disabled % ENABLE_EVERY == 1:
            self._driver.command(RigAction.ENABLE)
        if self._disabled > ENABLE_PATIENCE:
            self._overdue()

    def _overdue(self) -> None:
        with self._lock:
            waiting, self._pending = self._pending, None
        if waiting is not None:
            self._end(waiting, RunState.FAILED, "the rig's amplifier could not be enabled")

    def _gap(self, seq: int) -> int:
        """Samples the rig skipped before ``seq`` (it fell behind its clock, or lost them);
        none after a (re)connection."""
        last, self._seq = self._seq, seq
        if last is None:
            return 0
        gap = (seq - last - 1) % 2**32
        return gap if gap < MAX_GAP else 0

    def _dropped(self, active: ActiveRun, gap: int) -> None:
        """The samples the rig skipped, recorded where they belong on the rig's clock: the
        reference, the voltage the amplifier held, and NaN for what nobody measured (a
        recording's sample k stays at t = k·Ts)."""
        nan = math.nan
        for _ in range(min(gap, active.run.n_samples - active.k)):
            r, _e = active.exogenous(active.k)
            self._row(active, [r, active.u, nan, nan, nan, nan, nan])
            active.k += 1
            active.dropped += 1

    def _settling(self, theta_dot: float, alpha_dot: float) -> float:
        """Between runs: 0 V; after one, settle and re-zero."""
        settle = self.settle
        if settle is None:
            return 0.0
        settle = settle_step(settle, self.settle_limits, self._t, theta_dot, alpha_dot)
        if settle.phase is SettlePhase.REZERO and self._driver is not None:
            self._driver.command(RigAction.ZERO)
            self._theta_dot.last = self._alpha_dot.last = None
            settle = rezeroed(settle)
        if settle.phase is SettlePhase.OUT_OF_SERVICE and self.settle is not settle:
            log.error("rig: %s", settle.message)
        self.settle = None if settle.phase is SettlePhase.READY else settle
        return 0.0

    def _row(self, active: ActiveRun, row: list[float]) -> None:
        if active.rows is None:
            active.rows, active.k0 = [], active.k
        active.rows.append(row)
        if len(active.rows) >= self.settings.block:
            self._flush(active)

    def _flush(self, active: ActiveRun) -> None:
        if not active.rows:
            return
        data = np.asarray(active.rows, dtype=np.float64)[None]
        block = Block([active.record.id], [active.k0], data)
        active.rows = None
        self.recorder.append(block)
        self._events.blocks(self.id, [block])

    def _finish(self, active: ActiveRun, state: RunState, reason: str | None) -> None:
        """In the loop: the run ends at sample ``active.k``; 0 V from the next answer, then
        the settle."""
        with self._lock:
            if self._active is active:
                self._active = None
            self.settle = begin_settle(self._t)
        self._flush(active)
        self._end(active, state, reason)

    def _end(self, active: ActiveRun, state: RunState, reason: str | None) -> None:
        active.law.close()
        self.recorder.status(active.record.id, state, reason, None, active.k)
        self._events.changed(self.id, Changed(active.record.id, state, active.k, reason))
        with self._ended_lock:  # (the caller may hold self._lock)
            self._ended.append(active.record.id)

    # -- the emergency stop ----------------------------------------------------------
    def emergency_stop(self, who: str) -> None:
        """From any thread (the e-stop socket's, a command's): the loop's next answer is
        0 V with the amplifier disabled, and the run on the rig ends ``stopped``."""
        with self._lock:
            self._estop = who
        log.warning("rig: emergency stop by %s", who)

    def _emergency(self, who: str) -> None:
        """In the loop, the lock held: disable the amplifier, end the run (if any)."""
        self._estop = None
        if self._driver is not None:
            self._driver.command(RigAction.STOP)
        reason = f"emergency stop by {who}: 0 V and the amplifier disabled"
        for run in (self._active, self._pending):
            if run is not None and run.stop is None:
                run.stop = (RunState.STOPPED, reason, None)
