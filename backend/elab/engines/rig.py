"""The rig engine: the host loop of one flexible-link rig, in an engine process of its own.

The rig is the clock (:mod:`elab.rig.driver`): the loop thread blocks on the rig's next
sample, computes the run's voltage, passes it through the trusted
:class:`~elab.rig.supervisor.Supervisor` and answers the same sample. Between runs it
answers 0 V, so the rig's watchdog stays quiet and the link is watched all the time. The
samples go to the engine's :class:`~elab.engines.recorder.Recorder` and out to the web
process in blocks, exactly as a simulation's do, so watchers, downloads and replays are
the same. A trip ends the run ``failed`` with its reason and sample; a silent or lost
rig ends it ``failed`` with what it recorded. After every run the loop holds 0 V until
the link is still, re-zeroes the rig (:mod:`elab.rig.settle`), and only then takes the
next run; a rig that does not settle is out of service until the engine restarts.

The controller is the run's law as the simulation compiles it (:func:`compile_run`),
stepped one sample at a time by the same compiled arithmetic
(:func:`elab.sim.kernel.control_step`) on the measured θ and α, with the run's reference
and excitation (:meth:`CompiledRun.exogenous`; the rig's sensors are real, so a run's
simulated noise and quantisation are left out): a law that needs the true state (state
feedback without an estimate) cannot run here. A store write (a new run's record) never
happens under the lock the loop takes every sample.
"""

from __future__ import annotations

import logging
import math
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from elab.engines.base import (
    Action,
    Block,
    Changed,
    EngineEvents,
    Health,
    NewParams,
    RigLink,
    RunOrder,
    StoreHealth,
)
from elab.engines.recorder import Recorder
from elab.engines.ticks import realtime_thread
from elab.errors import Conflict, ElabError, InvalidInput, Unavailable
from elab.laws import is_code, law_kind
from elab.lifecycle import RunState
from elab.plants import get_plant
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
from elab.rig.supervisor import SafetyLimits, Supervisor, Trip
from elab.sim.kernel import control_step
from elab.sim.spec import CompiledRun, RunSpec, compile_run
from elab.store.base import ParamChange, RunRecord, RunStore

EXO_BLOCK = 1000  # samples of reference and excitation computed at once
ENABLE_EVERY = 50  # samples between two requests to enable a disabled amplifier
ENABLE_PATIENCE = 1000  # samples a new run waits for the amplifier before it fails

log = logging.getLogger(__name__)

Array = NDArray[np.float64]
CRASHED = "the rig engine ended while the run was live (crash or restart)"
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


@dataclass(frozen=True)
class RigSettings:
    """``address``: the rig's ``host:port`` (E-Lab's byte protocol); ``sample_timeout``:
    s without a sample before the rig counts as silent (its run fails); ``block``:
    samples per block to the recorder and the watchers (20 ms at 1 kHz); ``realtime``:
    the loop thread's SCHED_FIFO priority (0: none); ``omega_c``: rad/s of the
    differentiators that estimate θ̇ and α̇ for the record and the supervisor (the seed's
    velocity filter for θ); the store's settings as the simulation engine's."""

    address: str = "127.0.0.1:7100"
    sample_timeout: float = 0.1
    block: int = 20
    realtime: int = 0
    omega_c: float = 150.0
    still_for: float = 2.0  # s the link must be still after a run before the next
    flush_interval: float = 0.25
    retry_for: float = 30.0
    max_pending: int = 256 << 20


@dataclass
class _Active:
    """The run the loop steps now: its controller as the loop steps it (``law``), the
    rows not yet handed on (from sample ``k0``), its reference and excitation for samples
    ``exo_k0 ..`` (``exo``: rows ``[r, e, …]``), and whether it was asked to end."""

    record: RunRecord
    law: _Law
    supervisor: Supervisor
    k: int = 0
    rows: list[list[float]] | None = None
    k0: int = 0
    exo: Array | None = None
    exo_k0: int = 0
    stop: tuple[RunState, str | None, Future[int] | None] | None = None

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


class RigEngine:
    """Steps one run at a time on one rig; every method is safe to call from any thread."""

    def __init__(
        self,
        engine_id: str,
        store: RunStore,
        events: EngineEvents,
        settings: RigSettings,
        connect: Callable[[], Driver],
        limits: SafetyLimits | None = None,
    ) -> None:
        self.id = engine_id
        self.store = store
        self.settings = settings
        self.limits = limits or SafetyLimits()
        self._events = events
        self._connect = connect
        self.recorder = Recorder.reporting(
            store,
            engine_id,
            events,
            interval=settings.flush_interval,
            retry_for=settings.retry_for,
            max_pending=settings.max_pending,
            on_fault=self._on_fault,
        )
        self._lock = threading.Lock()
        self._active: _Active | None = None
        self._pending: _Active | None = None  # added, starting at the next sample
        self._reserved = False  # a run is being stored, outside the lock
        self._swaps: list[tuple[CompiledRun, Future[int]]] = []  # changes, in order
        self._closing = threading.Event()
        self._driver: Driver | None = None
        self._thread = threading.Thread(target=self._loop, name="elab-rig-loop", daemon=True)
        self.identity: RigIdentity | None = None
        self.problem: str | None = "not connected yet"
        self.last_sample = 0.0  # monotonic s
        self._latency = _Latency()
        self._disabled = 0  # samples in a row the amplifier was off between runs
        self.settle_limits = SettleLimits(still_for=settings.still_for)
        self.settle: Settle | None = None  # after a run, until the rig is ready again
        self._t = 0.0  # s, the rig's clock: samples since connecting times Ts
        self._theta_dot = _Differentiator(settings.omega_c)
        self._alpha_dot = _Differentiator(settings.omega_c)

    # -- lifecycle -------------------------------------------------------------------
    def start(self) -> list[str]:
        interrupted = self.store.mark_interrupted(self.id, CRASHED)
        _warm()  # compile the controller step now, not on a live sample (about a second)
        self.recorder.start()
        self._thread.start()
        return interrupted

    def close(self, reason: str = "server shut down") -> None:
        with self._lock:
            active = self._active or self._pending
            if active is not None and active.stop is None:
                active.stop = (RunState.INTERRUPTED, reason, None)
        deadline = time.monotonic() + 5.0
        while self._busy() and time.monotonic() < deadline and self._thread.is_alive():
            time.sleep(0.01)
        self._closing.set()
        self._thread.join(5.0)
        with self._lock:  # a rig that never answered: its run ends here
            active, self._active, self._pending = self._active or self._pending, None, None
        if active is not None:
            self._end(active, RunState.INTERRUPTED, reason)
        self.recorder.close()

    def _busy(self) -> bool:
        with self._lock:
            return self._active is not None or self._pending is not None or self._reserved

    # -- commands --------------------------------------------------------------------
    def add(self, order: RunOrder) -> RunRecord:
        """Check the run, store it and start it at the rig's next sample."""
        if self.recorder.failed:
            raise Unavailable("new runs are refused while the run store fails", retry_after=5.0)
        if self.identity is None:
            raise Unavailable(f"the rig is not connected: {self.problem}", retry_after=5.0)
        with self._lock:  # before compiling too: a refused run costs the loop's GIL nothing
            self._check_free()
        run = _compile(order)
        with self._lock:
            self._check_free()
            self._reserved = True
        try:
            now = time.time()
            record = RunRecord(
                id=order.id,
                plant=order.spec.plant.id,
                mode=order.mode,
                experiment=order.experiment,
                spec=order.request,
                status=RunState.RUNNING.value,
                Ts=run.Ts,
                channels=CHANNELS,
                n_planned=run.n_samples,
                created_at=now,
                started_at=now,
                engine=self.id,
                owner=order.owner,
                private=order.private,
            )
            self.store.create_run(record)  # not under the lock: the loop takes it
            self.recorder.open(record.id, len(CHANNELS))
            active = _Active(record, _Law.of(run), Supervisor(self.limits, run.Ts))
        finally:
            with self._lock:
                self._reserved = False
        with self._lock:
            self._pending = active
        self._events.started(self.id, record)
        return record

    def _check_free(self) -> None:
        """With the lock held: :class:`Conflict` unless the rig can take a run now."""
        busy = self._active or self._pending
        if busy is not None:
            raise Conflict(f"the rig is driven by run {busy.record.id}; one run at a time")
        if self._reserved:
            raise Conflict("the rig is taking another run; one run at a time")
        settle = self.settle
        if settle is not None and settle.phase is SettlePhase.OUT_OF_SERVICE:
            raise Unavailable(f"the rig is out of service: {settle.message}")
        if settle is not None:
            raise Conflict(
                "the rig is settling after the last run (0 V until the link is still, "
                "then it re-zeroes); try again in a few seconds"
            )

    def control(self, run_id: str, action: Action, reason: str | None = None) -> Future[int]:
        """Stop at the next sample (0 V from there); a rig run does not pause."""
        fut: Future[int] = Future()
        if action != "stop":
            fut.set_exception(
                Conflict(
                    f"a run on the rig cannot {action}: the motor would hold no position; "
                    "stop it and start a new one"
                )
            )
            return fut
        with self._lock:
            active = self._active if self._active and self._active.record.id == run_id else None
            active = active or (
                self._pending if self._pending and self._pending.record.id == run_id else None
            )
            if active is None or active.stop is not None:
                fut.set_exception(Conflict(f"run {run_id} has ended: it no longer steps"))
                return fut
            active.stop = (RunState.STOPPED, reason, fut)
        return fut

    def replace(self, run_id: str, new: NewParams) -> int:
        law, reference = new.law, new.reference
        with self._lock:
            active = self._active or self._pending
            if active is None or active.record.id != run_id or active.stop is not None:
                raise Conflict(f"run {run_id} has ended: it no longer steps")
            old = active.run
        if law is not None and is_code(law):
            raise InvalidInput("controller", "code", "a declarative law on a rig run")
        spec = replace(old.spec, law=law or old.spec.law, reference=reference or old.spec.reference)
        run = _compile_spec(spec)
        if run.controller.nc != old.controller.nc:
            raise InvalidInput(
                "controller",
                law_kind(law) if law is not None else None,
                f"a {type(old.spec.law).__name__} law like the run's (its controller state "
                "size cannot change mid-run); start a new run instead",
            )
        applied: Future[int] = Future()
        with self._lock:
            self._swaps.append((run, applied))
        try:
            k = applied.result(timeout=5.0)
        except TimeoutError:
            raise Unavailable(
                "the rig sent no sample for 5 s: the change was not applied"
            ) from None
        change = ParamChange(k=k, params=new.asked, at=time.time())
        self.recorder.param(run_id, change)
        self._events.params(self.id, run_id, change)
        return k

    # -- health ----------------------------------------------------------------------
    def health(self) -> Health:
        """The rig's link and the loop's response latency (µs from a sample's arrival to
        its answer sent), the store."""
        now = time.monotonic()
        stepping = self._thread.is_alive() and (
            self.identity is None or now - self.last_sample < 1.0
        )
        store = self.recorder.health
        store = replace(store, pending_bytes=self.recorder.pending_bytes())
        timing: dict[str, float | int] = self._latency.summary()
        timing["connected"] = int(self.identity is not None)
        rig, settle = self.identity, self.settle
        out = settle is not None and settle.phase is SettlePhase.OUT_OF_SERVICE
        link = RigLink(
            connected=rig is not None,
            rig_id=None if rig is None else rig.rig_id,
            firmware=None if rig is None else rig.firmware,
            emulated=rig is not None and rig.emulated,
            problem=settle.message if out and settle is not None else self.problem,
            settling=settle is not None and not out,
        )
        return Health(
            rig=link,
            engine=self.id,
            pid=os.getpid(),
            live_runs=int(self._busy()),
            timing=timing,
            store=store,
            stepping=stepping,
            at=time.time(),
        )

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
        theta_dot = self._theta_dot.next(s.theta, Ts)
        alpha_dot = self._alpha_dot.next(s.alpha, Ts)
        enabled = s.status & Status.MOTOR_ENABLED and not s.status & Status.WATCHDOG_TRIPPED
        with self._lock:
            waiting = self._pending
            if waiting is not None and waiting.stop is not None:  # stopped before it began
                self._pending = None
                self._end(waiting, waiting.stop[0], waiting.stop[1])
                if waiting.stop[2] is not None:
                    waiting.stop[2].set_result(0)
            if self._active is None and self._pending is not None and enabled:
                self._active, self._pending = self._pending, None
                self._theta_dot.reset(s.theta)
                self._alpha_dot.reset(s.alpha)
                theta_dot = alpha_dot = 0.0
            active, swaps, self._swaps = self._active, self._swaps, []
        self._t += Ts
        if enabled:
            self._disabled = 0
        for run, applied in swaps:
            if active is None:
                applied.set_exception(Conflict("the run ended before its change"))
                continue
            active.law = _Law.of(run, active.law.xc)  # the controller's state goes on
            active.exo = None
            active.supervisor.touch(active.k * run.Ts)
            applied.set_result(active.k)
        if active is None:
            if not enabled:
                self._enable()
            return self._settling(theta_dot, alpha_dot)
        if active.stop is not None:
            state, reason, fut = active.stop
            self._finish(active, state, reason)
            if fut is not None:
                fut.set_result(active.k)
            return 0.0
        run, k = active.run, active.k
        t = k * run.Ts
        r, e = active.exogenous(k)
        u_req = self._control(active.law, r, e, s)
        if not math.isfinite(u_req):  # the law's arithmetic overflowed: nothing to apply
            self._row(active, [r, 0.0, s.theta, s.alpha, theta_dot, alpha_dot, 0.0])
            active.k += 1
            reason = (
                f"the controller's voltage is {u_req} at t = {t:.4g} s: its numbers overflow "
                "(a reference or gain too large); 0 V since"
            )
            self._finish(active, RunState.FAILED, reason)
            return 0.0
        fault = bool(s.status & Status.WATCHDOG_TRIPPED)
        decision = active.supervisor.step(
            k, t, s.theta, s.alpha, theta_dot, u_req, False, fault=fault
        )
        u = decision.u_applied
        latency = (time.monotonic_ns() - s.received_ns) * 1e-9
        self._row(active, [r, u, s.theta, s.alpha, theta_dot, alpha_dot, latency])
        active.k += 1
        if decision.trip is not None:
            self._finish(active, RunState.FAILED, _tripped(decision.trip))
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

    def _control(self, law: _Law, r: float, e: float, s: RigSample) -> float:
        law.z[0], law.z[1] = s.theta, s.alpha
        u = control_step(
            0, r, law.z, e, law.Ac, law.Bc, law.Cc, law.Dc, law.Lw, law.u_lim, law.xc, law.xcn
        )
        law.xc[0, :] = law.xcn
        return float(u)

    def _row(self, active: _Active, row: list[float]) -> None:
        if active.rows is None:
            active.rows, active.k0 = [], active.k
        active.rows.append(row)
        if len(active.rows) >= self.settings.block:
            self._flush(active)

    def _flush(self, active: _Active) -> None:
        if not active.rows:
            return
        data = np.asarray(active.rows, dtype=np.float64)[None]
        block = Block([active.record.id], [active.k0], data)
        active.rows = None
        self.recorder.append(block)
        self._events.blocks(self.id, [block])

    def _finish(self, active: _Active, state: RunState, reason: str | None) -> None:
        """In the loop: the run ends at sample ``active.k``; 0 V from the next answer, then
        the settle."""
        with self._lock:
            if self._active is active:
                self._active = None
            self.settle = begin_settle(self._t)
        self._flush(active)
        self._end(active, state, reason)

    def _end(self, active: _Active, state: RunState, reason: str | None) -> None:
        self.recorder.status(active.record.id, state, reason, None, active.k)
        self._events.changed(self.id, Changed(active.record.id, state, active.k, reason))

    def _on_fault(self, health: StoreHealth) -> None:
        self._events.health(self.id, self.health())
        if not health.ok and not health.transient:
            with self._lock:
                active = self._active
                if active is not None and active.stop is None:
                    active.stop = (RunState.FAILED, f"storage failed: {health.error}", None)


def _compile(order: RunOrder) -> CompiledRun:
    if is_code(order.spec.law):
        raise InvalidInput(
            "controller",
            "code",
            "a declarative controller (state feedback with an estimate, PID, tf/ss): Python "
            "controllers on the rig are not supported yet",
        )
    return _compile_spec(order.spec)


def _compile_spec(spec: RunSpec) -> CompiledRun:
    """The run as the loop steps it: its sensors are the rig's, not simulated ones."""
    run = compile_run(replace(spec, noise_seed=None, quantize=False))
    if run.controller.feedback != "output":
        raise InvalidInput(
            "controller.estimate",
            "true state",
            "velocity_filters or observer: on the rig a controller sees only the measured "
            "θ and α, never the true state",
        )
    return run


def _tripped(trip: Trip) -> str:
    return f"safety trip ({trip.reason}) at sample {trip.k}: {trip.message}; 0 V since"


@dataclass
class _Law:
    """A run's discrete controller as :func:`control_step` takes it (slot 0 of one)."""

    run: CompiledRun
    Ac: Array
    Bc: Array
    Cc: Array
    Dc: Array
    Lw: Array
    u_lim: Array
    xc: Array  # (1, nc): the controller's state
    xcn: Array  # (nc,): its next state
    z: Array  # (2,): θ and α as measured

    @classmethod
    def of(cls, run: CompiledRun, xc: Array | None = None) -> _Law:
        c = run.controller
        return cls(
            run,
            c.Ac[None].copy(),
            c.Bc[None].copy(),
            c.Cc[None].copy(),
            c.Dc[None].copy(),
            c.Lw[None].copy(),
            np.array([run.u_lim]),
            np.zeros((1, c.nc)) if xc is None else xc,
            np.zeros(c.nc),
            np.zeros(2),
        )


def _warm() -> None:
    plant = get_plant("flexible_link")
    law = _Law.of(_compile_spec(RunSpec(plant, plant.predefined, duration=0.01)))
    control_step(
        0, 0.0, law.z, 0.0, law.Ac, law.Bc, law.Cc, law.Dc, law.Lw, law.u_lim, law.xc, law.xcn
    )


class _Differentiator:
    """θ̇ from θ: the filter ωc s / (s + ωc) discretised by backward Euler."""

    def __init__(self, omega_c: float) -> None:
        self.omega_c = omega_c
        self.last: float | None = None
        self.value = 0.0

    def reset(self, x: float) -> None:
        self.last, self.value = x, 0.0

    def next(self, x: float, Ts: float) -> float:
        if self.last is None:
            self.last = x
            return 0.0
        a = 1.0 / (1.0 + self.omega_c * Ts)
        self.value = a * self.value + (1 - a) * (x - self.last) / Ts
        self.last = x
        return self.value


class _Latency:
    """Response latencies over the last 10,000 samples (ns in, µs out)."""

    def __init__(self, keep: int = 10_000) -> None:
        self._ns = np.zeros(keep, dtype=np.int64)
        self._n = 0
        self.late_1ms = 0  # answers later than 1 ms, all time
        self.samples = 0

    def add(self, ns: int) -> None:
        self._ns[self._n % self._ns.size] = ns
        self._n += 1
        self.samples += 1
        self.late_1ms += ns > 1_000_000

    def summary(self) -> dict[str, float | int]:
        n = min(self._n, self._ns.size)
        if n == 0:
            return {"samples": 0, "late_1ms": 0}
        us = self._ns[:n] / 1e3
        return {
            "samples": self.samples,
            "late_1ms": self.late_1ms,
            "latency_p50_us": float(np.percentile(us, 50)),
            "latency_p99_us": float(np.percentile(us, 99)),
            "latency_max_us": float(us.max()),
        }
