"""The batched simulation engine: a stepping thread and a writer thread over one store.

:class:`SimulationEngine` is what runs inside an engine process (see
:mod:`elab.engines.process`): runs are added, controlled and changed through it,
it steps them in one :class:`~elab.engines.stepper.Stepper`, records every sample
and change through its :class:`~elab.engines.recorder.Recorder`, and reports
everything to an :class:`~elab.engines.base.EngineEvents` (called from its
threads; the process forwards each call over its socket).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import replace

import numpy as np

from elab.controllers.sandbox import ControllerFailed
from elab.engines.base import (
    Action,
    Block,
    Changed,
    EngineEvents,
    Health,
    NewParams,
    RunOrder,
    StoreHealth,
)
from elab.engines.coded import CodedRun
from elab.engines.outcome import OutcomeTracker
from elab.engines.recorder import Recorder
from elab.engines.settings import EngineSettings
from elab.engines.stepper import Stepper
from elab.errors import Conflict, ElabError, InvalidInput, TooMany, Unavailable
from elab.laws import CodeController, is_code, law_kind
from elab.lifecycle import RunState
from elab.plants import get_plant
from elab.sim.batch import Batch
from elab.sim.result import Samples
from elab.sim.spec import CompiledRun, RunSpec, compile_run
from elab.store.base import ParamChange, RunRecord, RunStore

log = logging.getLogger(__name__)

#: why runs an engine left live are interrupted when it starts again
CRASHED = "the engine stopped while the run was live (its process ended unexpectedly)"


def channels_of(run: CompiledRun) -> tuple[tuple[str, str], ...]:
    """Recorded columns ``r, u, y…, x…`` with units (the time column is derived)."""
    p = run.spec.plant
    empty = Samples(
        p, run.Ts, 0, np.zeros(0), np.zeros(0), np.zeros((0, p.ny)), np.zeros((0, p.nx))
    )
    return tuple((c.name, c.unit) for c, _ in empty.channels()[1:])


class SimulationEngine:
    """Steps and records runs; every method is safe to call from any thread."""

    def __init__(
        self,
        engine_id: str,
        store: RunStore,
        events: EngineEvents,
        settings: EngineSettings | None = None,
        *,
        backlog: Callable[[], bool] = lambda: False,
    ) -> None:
        self.id = engine_id
        self.store = store
        self._events = events
        self.settings = settings = settings or EngineSettings()
        self.recorder = Recorder.reporting(store, engine_id, events, settings, self._on_fault)
        self._backlog = backlog
        self.stepper = Stepper(
            self._on_tick, tick=settings.tick, backlog=backlog, realtime=settings.realtime
        )
        # runs with code controllers, each stepped by a stepper (a thread) of its own
        self._coders: dict[str, Stepper] = {}
        self._runs: dict[str, CompiledRun] = {}  # live runs as last changed
        self._orders: dict[str, RunOrder] = {}  # what each live run was started with
        self._changing = threading.Lock()
        self._code_runs = 0  # live runs with a code controller, and those starting
        self._counting = threading.Lock()

    # -- lifecycle -----------------------------------------------------------------
    def start(self) -> list[str]:
        """Mark the runs this engine left live interrupted, load the compiled loop, and
        start stepping; returns the interrupted runs."""
        interrupted = self.store.mark_interrupted(self.id, CRASHED)
        _warm()  # the first call loads the compiled loop from disk: not on a live tick
        self.recorder.start()
        self.stepper.start()
        return interrupted

    def close(self, reason: str = "server shut down") -> None:
        """Interrupt the live runs with ``reason`` and store everything."""
        for stepper in self._steppers():
            try:
                stepper.end(None, RunState.INTERRUPTED, reason).result(timeout=10)
            except (TimeoutError, Conflict):
                log.error("a stepping thread did not answer; closing anyway")
            stepper.close()
        self.recorder.close()

    def _steppers(self) -> list[Stepper]:
        """The shared stepper and those of the live code runs."""
        return [self.stepper, *list(self._coders.values())]

    def _stepper_of(self, run_id: str) -> Stepper:
        return self._coders.get(run_id, self.stepper)

    # -- commands ---------------------------------------------------------------------
    def add(self, order: RunOrder) -> RunRecord:
        """Check, store and start a run; its record."""
        if self.recorder.failed:
            h = self.recorder.health
            raise Unavailable(
                f"new runs are refused while the run store fails: {h.error}", retry_after=5.0
            )
        run = compile_run(order.spec)
        match run.spec.law:
            case CodeController() as law:
                coded: CodedRun | None = self._start_coded(run, law)
            case _:
                coded = None
        try:
            return self._add(order, run, coded)
        except BaseException:
            if coded is not None:
                coded.close()
                self._ended_coded()
            raise

    def _add(self, order: RunOrder, run: CompiledRun, coded: CodedRun | None) -> RunRecord:
        mono = time.monotonic()
        # sample 0 just after the stepper's next tick, so each tick completes a frame;
        # started_at: the wall time of sample 0
        origin = self.stepper.origin(mono, run.Ts) if order.pace == "realtime" else mono
        now = time.time() + (origin - mono)
        record = RunRecord(
            id=order.id,
            plant=order.spec.plant.id,
            mode=order.mode,
            experiment=order.experiment,
            spec=order.request,
            status=RunState.RUNNING.value,
            Ts=run.Ts,
            channels=channels_of(run),
            n_planned=run.n_samples,
            created_at=now,
            started_at=now,
            engine=self.id,
            owner=order.owner,
            private=order.private,
        )
        self.store.create_run(record)
        self.recorder.open(record.id, len(record.channels), OutcomeTracker.of(run, record.channels))
        self._runs[record.id] = run
        self._orders[record.id] = order
        self._events.started(self.id, record, order)
        stepper = self.stepper
        if coded is not None:  # its own thread: a slow controller delays only its run
            stepper = Stepper(
                self._on_tick,
                tick=self.settings.tick,
                backlog=self._backlog,
                lone=True,
                ordinary=True,
            )
            self._coders[record.id] = stepper
            stepper.start()
        stepper.add(record.id, run, order.pace, t_origin=origin, coded=coded)
        return record

    def _start_coded(self, run: CompiledRun, law: CodeController) -> CodedRun:
        """Start a code controller's process (at most ``max_code_runs`` at once)."""
        limit = self.settings.max_code_runs
        with self._counting:
            if self._code_runs >= limit:
                raise TooMany(
                    f"{limit} runs with Python controllers are live on this engine, its "
                    f"limit (ELAB_MAX_CODE_RUNS); try again when one has ended",
                    retry_after=10.0,
                )
            self._code_runs += 1
        try:
            return CodedRun(
                run,
                self.settings.code,
            )
        except ControllerFailed as exc:
            self._ended_coded()
            raise InvalidInput("controller", law.name, f"a controller that starts: {exc}") from None
        except BaseException:
            self._ended_coded()
            raise

    def _ended_coded(self) -> None:
        with self._counting:
            self._code_runs -= 1

    def control(self, run_id: str, action: Action, reason: str | None = None) -> Future[int]:
        return self._stepper_of(run_id).control(run_id, action, reason)

    def replace(self, run_id: str, new: NewParams) -> int:
        """A new law and/or reference from the next sample on; the change is recorded and
        reported; returns that sample's index."""
        law, reference = new.law, new.reference
        with self._changing:  # one change at a time: each starts from the last
            old = self._runs.get(run_id)
            if old is None:
                raise Conflict(f"run {run_id} has ended: it no longer steps")
            if law is not None and CodeController in (type(law), type(old.spec.law)):
                raise InvalidInput(
                    "controller",
                    law_kind(law),
                    "a declarative law on a run with one: a Python controller cannot be "
                    "swapped in or out mid-run; start a new run",
                )
            spec = replace(
                old.spec, law=law or old.spec.law, reference=reference or old.spec.reference
            )
            run = compile_run(spec)
            if law is not None and run.controller.nc != old.controller.nc:
                raise InvalidInput(
                    "controller",
                    law_kind(law),
                    f"a {type(old.spec.law).__name__} law like the run's (its "
                    "controller state size cannot change mid-run); start a new "
                    "run instead",
                )
            k = (
                self._stepper_of(run_id)
                .replace(run_id, run, controller=law is not None, signals=reference is not None)
                .result()
            )
            self._runs[run_id] = run
        change = ParamChange(k=k, params=new.asked, at=time.time())
        self.recorder.param(run_id, change)
        self._events.params(self.id, run_id, change, new)
        return k

    def follow(self) -> int:
        """Each live run reported again as started: its record as stored now and its order
        with the law and reference it steps by now; then a paused one's state."""
        with self._changing:  # not half-way through a change
            live = [
                (replace(order, spec=self._runs[run_id].spec), run_id)
                for run_id, order in self._orders.items()
                if run_id in self._runs
            ]
        said = 0
        for order, run_id in live:
            try:
                record = self.store.get_run(run_id)
            except ElabError:  # ended and gone meanwhile, or the store fails: not said
                continue
            if not RunState(record.status).live:
                continue
            self._events.started(self.id, record, order)
            if record.status == RunState.PAUSED.value:
                self._events.changed(self.id, Changed(run_id, RunState.PAUSED, record.n_stored))
            said += 1
        return said

    # -- health ---------------------------------------------------------------------
    def health(self) -> Health:
        """Live runs, the stepping threads' timing (the shared one's, and how far the code
        runs' clocks lag), the store, and whether both shared threads are alive and working
        (the stepper began a tick within a second, the writer finished a try within its
        longest wait)."""
        now = time.monotonic()
        quiet = now - self.stepper.last_tick
        stepping = self.stepper.alive and quiet < max(1.0, 10 * self.stepper.tick)
        store = self.recorder.health
        if not (self.recorder.alive and now - self.recorder.last_flush < 10.0):
            store = StoreHealth(
                ok=False, error="the writer thread is not working", since=store.since or time.time()
            )
        store = replace(store, pending_bytes=self.recorder.pending_bytes())
        timing = self.stepper.timing()
        coders = [c.timing() for c in list(self._coders.values())]
        timing["code_runs"] = len(coders)
        timing["code_clock_lag_max_ms"] = max((c["clock_lag_max_ms"] for c in coders), default=0.0)
        return Health(
            engine=self.id,
            pid=os.getpid(),
            live_runs=self.stepper.live_count + len(coders),
            timing=timing,
            store=store,
            stepping=stepping,
            at=time.time(),
        )

    # -- from the threads ------------------------------------------------------------
    def _on_tick(self, blocks: list[Block], changes: list[Changed]) -> None:
        """In the stepping thread: record, then report."""
        for b in blocks:
            self.recorder.append(b)
        if blocks:
            self._events.blocks(self.id, blocks)
        for c in changes:
            self.recorder.status(c.run_id, c.state, c.error, c.compute, c.k)
            if not c.state.live:
                run = self._runs.pop(c.run_id, None)
                self._orders.pop(c.run_id, None)
                self._coders.pop(c.run_id, None)  # its thread ends by itself
                if run is not None and is_code(run.spec.law):
                    self._ended_coded()
            self._events.changed(self.id, c)

    def _on_fault(self, health: StoreHealth) -> None:
        """In the writer thread: a failed store fails the live runs. The health report goes
        out first, so whoever sees a run fail for it already sees the store failed."""
        self._events.health(self.id, self.health())
        if not health.ok and not health.transient:
            for stepper in self._steppers():
                stepper.end(
                    None,
                    RunState.FAILED,
                    f"storage failed: {health.error}; the recording keeps the samples stored "
                    "before",
                )


def _warm() -> None:
    batch = Batch(capacity=1, block=8)
    plant = get_plant("flexible_link")
    batch.add(compile_run(RunSpec(plant, plant.predefined, duration=0.01)))
    batch.advance(8)
