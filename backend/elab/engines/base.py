"""What steps runs: the :class:`Engine` protocol, what it is given and what it reports.

The run manager (web side) talks to every engine through :class:`Engine` and hears
from it through :class:`EngineEvents`. An engine owns its runs while they are
live: it decides every command on them (one state machine, in one thread), steps
them, and records every sample and every change in the store itself, so nothing
the web process does can delay or lose a sample. The messages are plain data
(:mod:`elab.engines.wire` carries them between processes), so the boundary can
later cross machines through a broker without changing the run manager.
"""

from __future__ import annotations

from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Literal, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from elab.laws import ControlLaw
from elab.lifecycle import RunState
from elab.sim.signals import Signal
from elab.sim.spec import RunSpec
from elab.store.base import JsonObject, ParamChange, RunRecord

Array = NDArray[np.float64]
Pace = Literal["realtime", "fast"]
Action = Literal["pause", "resume", "stop"]


class Block(NamedTuple):
    """New samples of runs stepped together (one per plant and tick, not one per run: at
    300 runs the per-run objects and copies were a sixth of the server's CPU): run
    ``run_ids[i]`` has rows ``k0[i] .. k0[i]+n-1`` in ``data[i]`` (runs × n × columns)."""

    run_ids: list[str]
    k0: list[int]
    data: Array


@dataclass(frozen=True)
class RunOrder:
    """A run for an engine to start: its id (chosen by the caller), what to step, how fast,
    and what to record about it (``request``: the client's request, kept as it is)."""

    id: str
    spec: RunSpec
    pace: Pace
    mode: str
    experiment: str
    request: JsonObject
    owner: str | None = None  # the identity that started it (elab.access)
    private: bool = False


@dataclass(frozen=True)
class NewParams:
    """A live run's new law and/or reference, from the next sample on (``None``: keep it);
    ``asked``: the change as its client asked it, recorded with it and told to watchers."""

    law: ControlLaw | None = None
    reference: Signal | None = None
    asked: JsonObject = field(default_factory=dict)


@dataclass(frozen=True)
class Changed:
    """Run ``run_id`` entered ``state`` at sample ``k`` (``error``: why it failed, stopped
    early or was interrupted; why it paused, for a pause with a reason; only an ended
    run's is recorded). ``compute``: an ended code-controller run's compute time per step
    (:meth:`elab.controllers.sandbox.StepTimes.summary`)."""

    run_id: str
    state: RunState
    k: int
    error: str | None = None
    compute: dict[str, float | int] | None = None


@dataclass(frozen=True)
class Ended:
    """A run's final record as stored: its state, why it ended so (if not finished), and
    ``n``, the samples the recording holds. A run is ``finished`` only with every planned
    sample stored."""

    state: RunState
    error: str | None
    n: int


@dataclass(frozen=True)
class StoreHealth:
    """The engine's writes: ``ok``, or failing since ``since`` (unix s) with ``error``;
    ``transient``: being retried (a lock held elsewhere), else failed until someone acts.
    ``pending_bytes``: samples held in memory, not yet committed."""

    ok: bool = True
    error: str | None = None
    since: float | None = None
    transient: bool = False
    pending_bytes: int = 0


@dataclass(frozen=True)
class RigLink:
    """A rig engine's link to its rig: who the rig is (``emulated``: ``elab rig-emulator``,
    never hardware), whether it answers, and ``problem`` (why not connected, or out of
    service); ``settling``: after a run, until it is still and re-zeroed."""

    connected: bool
    rig_id: str | None = None
    firmware: str | None = None
    emulated: bool = False
    problem: str | None = None
    settling: bool = False


@dataclass(frozen=True)
class Health:
    """What an engine says about itself (every heartbeat). ``timing``: the simulation's
    stepping thread's (see Stepper.timing), or the rig loop's response latency."""

    engine: str
    pid: int
    live_runs: int
    timing: dict[str, float | int]
    store: StoreHealth = field(default_factory=StoreHealth)
    stepping: bool = True  # the stepping thread ticked recently
    at: float = 0.0  # unix s, when it was said
    rig: RigLink | None = None  # a rig engine's link


@dataclass(frozen=True)
class EngineStatus:
    """An engine as its user sees it: ``up`` (started and answering), else ``problem`` says
    why; ``problem`` also names what is wrong while up (a failed store, a stalled thread),
    ``warning`` what is being retried (a busy store). ``heartbeat_age``: seconds since it
    last reported (``None``: never)."""

    engine: str
    up: bool
    problem: str | None = None
    warning: str | None = None
    pid: int | None = None
    restarts: int = 0
    heartbeat_age: float | None = None
    health: Health | None = None


class EngineEvents(Protocol):
    """What an engine reports, delivered on the web process's event loop, in order."""

    def started(self, engine: str, record: RunRecord, order: RunOrder | None = None) -> None:
        """A run is stored and about to step (before any of its samples); ``order``: what
        it was started with."""

    def blocks(self, engine: str, blocks: list[Block]) -> None:
        """New samples (already handed to the engine's recorder)."""

    def changed(self, engine: str, change: Changed) -> None:
        """A run paused or resumed, or its stepping ended (its end is news once stored)."""

    def params(
        self, engine: str, run_id: str, change: ParamChange, new: NewParams | None = None
    ) -> None:
        """A run's parameters changed from sample ``change.k`` on (``new``: typed)."""

    def committed(self, engine: str, counts: dict[str, int]) -> None:
        """Samples ``[0, n)`` of each run are in the store."""

    def ended(self, engine: str, run_id: str, ended: Ended) -> None:
        """How an ended run ends, decided once its samples are committed (or dropped with a
        failed store): it will not change."""

    def stored(self, engine: str, run_id: str) -> None:
        """An ended run's final record is in the store."""

    def health(self, engine: str, health: Health) -> None:
        """A heartbeat."""

    def lost(self, engine: str, reason: str) -> None:
        """The engine is gone (its process died or stopped answering); its live runs are
        over. It restarts by itself if it can."""

    def resync(self, engine: str) -> None:
        """Some of the engine's messages were missed (a web process that fell behind its
        broker, a broker restarted): the store's records of its runs are the truth."""


class Engine(Protocol):
    """Steps runs. Commands are decided in the engine, one at a time, in the order they
    arrive: of two stops of one run exactly one succeeds, the other raises
    :class:`~elab.errors.Conflict`; a command for a run that has ended raises it too.
    :class:`~elab.errors.Unavailable` when the engine (or its store) cannot take it."""

    id: str

    async def start(self, events: EngineEvents) -> None:
        """Ready to take runs; runs this engine left live before (a crash) are marked
        interrupted first."""

    async def close(self) -> None:
        """Stop: live runs are interrupted ("server shut down"), everything is stored."""

    async def add(self, order: RunOrder) -> RunRecord:
        """Start stepping a run; its record, as stored."""

    async def control(self, run_id: str, action: Action, reason: str | None = None) -> int:
        """Pause, resume or stop a run; returns the sample index it happened at. ``reason``
        (who did it and why) goes with the change to the watchers and, for a stop, into
        the record."""

    async def replace(self, run_id: str, new: NewParams) -> int:
        """The run's new law and/or reference from the next sample on (recorded with
        ``new.asked``); returns that sample's index. :class:`InvalidInput` for a law whose
        controller state differs in size from the run's, or code swapped in or out."""

    def status(self) -> EngineStatus:
        """Up or not, why, and its last heartbeat."""

    def statuses(self) -> list[EngineStatus]:
        """Each engine process behind this one (one, or each engine on a broker)."""


class SteppingEngine(Protocol):
    """What an engine process runs (:mod:`elab.engines.child`), one per kind: the
    simulation (:class:`~elab.engines.simulation.SimulationEngine`) and the rig's host loop.
    Every method is safe to call from any thread; it reports through the
    :class:`EngineEvents` it was built with."""

    id: str

    def start(self) -> list[str]:
        """Ready to take runs; the ids of runs its earlier end left live, now interrupted."""

    def close(self, reason: str = "server shut down") -> None:
        """Live runs end interrupted with ``reason``; everything is stored."""

    def add(self, order: RunOrder) -> RunRecord:
        """Take a run (stored before it steps); its record."""

    def control(self, run_id: str, action: Action, reason: str | None = None) -> Future[int]:
        """Pause, resume or stop: the sample it happens at, once the stepping decided it."""

    def replace(self, run_id: str, new: NewParams) -> int:
        """As :meth:`Engine.replace`."""

    def follow(self) -> int:
        """Report each live run again as started (its record, the order it steps by now)
        and, if paused, its state; how many."""

    def health(self) -> Health:
        """Its heartbeat."""
