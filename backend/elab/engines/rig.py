"""The rig engine: the host loop of one flexible-link rig, in an engine process of its own
(the loop thread is :class:`~elab.engines.rigloop.HostLoop`; this module the engine's
commands around it, its health and what the rig's queue asks of it).

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

import hashlib
import json
import logging
import os
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import asdict, replace
from typing import Any, Protocol

from elab.engines.base import (
    Action,
    EngineEvents,
    Health,
    NewParams,
    RigLink,
    RunOrder,
    StoreHealth,
)
from elab.engines.outcome import OutcomeTracker
from elab.engines.recorder import Recorder
from elab.engines.riglaw import (
    RigLaw,
    compile_for_rig,
    law_for,
    warm,
)
from elab.engines.rigloop import CHANNELS, ActiveRun, HostLoop
from elab.engines.rigseat import SeatKeeper
from elab.engines.settings import RigSettings
from elab.errors import Conflict, InvalidInput, Unavailable
from elab.laws import CodeController, is_code, law_kind
from elab.lifecycle import RunState
from elab.rig.driver import Driver
from elab.rig.estop import EStopListener
from elab.rig.settle import (
    SettlePhase,
)
from elab.rig.supervisor import SafetyLimits, Supervisor
from elab.store.base import ParamChange, RigQueueStore, RunRecord, RunStore

log = logging.getLogger(__name__)
CRASHED = "the rig engine ended while the run was live (crash or restart)"

__all__ = ["CHANNELS", "RigEngine", "RigSettings", "RigStore"]


class RigStore(RunStore, RigQueueStore, Protocol):
    """The rig engine's store: the runs it records and the queue it follows."""


class RigEngine(HostLoop):
    """Steps one run at a time on one rig; every method is safe to call from any thread."""

    def __init__(
        self,
        engine_id: str,
        store: RigStore,
        events: EngineEvents,
        settings: RigSettings,
        connect: Callable[[], Driver],
        limits: SafetyLimits | None = None,
    ) -> None:
        recorder = Recorder.reporting(store, engine_id, events, settings, self._on_fault)
        super().__init__(engine_id, store, events, settings, connect, limits, recorder)
        self.store: RigStore = store
        self.seat = SeatKeeper(store, self, settings.seat)
        self._estops = (
            EStopListener(settings.estop, self.emergency_stop) if settings.estop else None
        )

    # -- lifecycle -------------------------------------------------------------------
    def start(self) -> list[str]:
        interrupted = self.store.mark_interrupted(self.id, CRASHED)
        self._ended.extend(interrupted)  # the queue hears of them at the keeper's first look
        warm()
        self.recorder.start()
        self._thread.start()
        if self._estops is not None:
            self._estops.start()
        self.seat.start()
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
        self.seat.close()
        if self._estops is not None:
            self._estops.close()
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
        self._check_seated(order)
        run = compile_for_rig(order.spec)
        with self._lock:
            self._check_free()
            self._reserved, self._taking = True, order.id
        law: RigLaw | None = None
        try:
            law = law_for(run, self.settings.code)  # a Python controller's process starts
            now = time.time()
            record = RunRecord(
                id=order.id,
                plant=order.spec.plant.id,
                mode=order.mode,
                experiment=order.experiment,
                spec={**order.request, "rig": self._facts(order)},
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
            self.recorder.open(record.id, len(CHANNELS), OutcomeTracker.of(run, CHANNELS))
            active = ActiveRun(record, law, Supervisor(self.limits, run.Ts))
        except BaseException:
            if law is not None:
                law.close()
            raise
        finally:
            with self._lock:
                self._reserved, self._taking = False, None
        with self._lock:
            self._pending = active
        self._events.started(self.id, record, order)
        return record

    def _facts(self, order: RunOrder) -> dict[str, Any]:
        """What a rig run records beside its request: the rig (identity, firmware,
        calibration), the safety limits it ran under and its controller's SHA-256 (the
        Python source, or the declarative law as requested), so that a run can be traced
        to the exact rig and controller."""
        rig = self.identity
        assert rig is not None  # add() checked
        match order.spec.law:
            case CodeController(source=source):
                text = source
            case _:
                text = json.dumps(order.request.get("controller"), sort_keys=True)
        return {
            "rig_id": rig.rig_id,
            "firmware": rig.firmware,
            "emulated": rig.emulated,
            "calibration": {
                "counts_per_rev": rig.counts_per_rev,
                "gauge_rad_per_count": rig.gauge_rad_per_count,
                "gauge_offset": rig.gauge_offset,
                "Ts": rig.Ts,
                "watchdog_samples": rig.watchdog_samples,
            },
            "safety": asdict(self.limits),
            "controller_sha256": hashlib.sha256(text.encode()).hexdigest(),
        }

    def _check_seated(self, order: RunOrder) -> None:
        """:class:`Conflict` unless the rig's queue has ``order`` on the rig (its driver
        armed the rig and started it: :mod:`elab.rig_queue`): one driver at a time is the
        store's decision, never this process's timing."""
        s = self.settings.seat
        q = self.store.rig_queue(s.rig, s.policy, time.time())
        if q.running != order.id:
            raise Conflict(
                f"run {order.id} does not hold the rig: join the rig's queue, arm the rig "
                "when your turn comes, then start the run (docs/rig.md)"
            )

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
                "the rig is settling (after every run and when it connects: 0 V until the "
                "link is still, then it re-zeroes); try again in a few seconds"
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

    def follow(self) -> int:
        """Nothing: a rig's engine is a process of the web process that started it, which
        follows its run from its start (rigs are not on a broker)."""
        return 0

    def replace(self, run_id: str, new: NewParams) -> int:
        law, reference = new.law, new.reference
        with self._lock:
            active = self._active or self._pending
            if active is None or active.record.id != run_id or active.stop is not None:
                raise Conflict(f"run {run_id} has ended: it no longer steps")
            old = active.run
        if law is not None and (is_code(law) or is_code(old.spec.law)):
            raise InvalidInput(
                "controller",
                law_kind(law),
                "a reference change only: a Python controller's run keeps its controller, "
                "and a declarative one is not swapped for code mid-run",
            )
        spec = replace(old.spec, law=law or old.spec.law, reference=reference or old.spec.reference)
        run = compile_for_rig(spec)
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
        self._events.params(self.id, run_id, change, new)
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

    # -- what the rig's queue asks (elab.engines.rigseat) ----------------------------
    def current_run(self) -> str | None:
        with self._lock:
            run = self._active or self._pending
            return None if run is None else run.record.id

    def taking(self) -> str | None:
        with self._lock:
            return self._taking

    def ended_runs(self) -> list[str]:
        with self._ended_lock:
            ended, self._ended = self._ended, []
        return ended

    def ready(self) -> bool:
        with self._lock:
            idle = self._active is None and self._pending is None and not self._reserved
        return idle and self.identity is not None and self.settle is None

    def unavailable(self) -> str | None:
        settle = self.settle
        if settle is not None and settle.phase is SettlePhase.OUT_OF_SERVICE:
            return settle.message
        if self.identity is None:
            return f"the rig does not answer: {self.problem}"
        return None

    def stop_for_queue(self, run_id: str, reason: str) -> None:
        with self._lock:
            for run in (self._active, self._pending):
                if run is not None and run.record.id == run_id and run.stop is None:
                    run.stop = (RunState.STOPPED, reason, None)

    def _on_fault(self, health: StoreHealth) -> None:
        self._events.health(self.id, self.health())
        if not health.ok and not health.transient:
            with self._lock:
                active = self._active
                if active is not None and active.stop is None:
                    active.stop = (RunState.FAILED, f"storage failed: {health.error}", None)
