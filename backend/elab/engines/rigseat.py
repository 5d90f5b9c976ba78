"""The rig engine and the rig's queue in the store kept agreeing (level-triggered).

The queue in the store (:mod:`elab.rig_queue`, one atomic operation per change) decides
who drives the rig; the rig engine runs only the run the queue says is on the rig
(:attr:`RigQueue.running`). A thread of the engine's process (never the loop's) compares
the two every ``every`` s and acts on any difference, so nothing depends on a message
arriving once:

- the engine's run is not the queue's running run (the slot ended, an instructor took
  over, an e-stop, someone left): the engine stops it;
- a run the engine ended: the queue hears :class:`RunEnded` (the rig then settles);
- the queue's running run never reached the engine (the web process died between seating
  it and starting it) for ``orphan`` s: it ended;
- the queue says the rig settles, the engine has it still and re-zeroed: :class:`Settled`;
- the rig silent, or out of service after a run, for ``out_after`` s: the queue takes it
  out of service with the reason (nobody is seated), and back when it answers again.

The web process changes the queue only through the store; a web process that is
stopped or restarted changes nothing here.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

from elab.errors import ElabError
from elab.rig_queue import (
    QueueOp,
    QueuePolicy,
    RigQueue,
    RunEnded,
    SetService,
    Settled,
)
from elab.store.base import RigQueueStore

log = logging.getLogger(__name__)


class SeatedEngine(Protocol):
    """What the keeper asks of the rig engine (all thread-safe)."""

    def current_run(self) -> str | None:
        """The run the engine steps or is about to (``None``: idle)."""
        ...

    def taking(self) -> str | None:
        """The run being added right now (stored, not yet stepping), if any."""
        ...

    def ended_runs(self) -> list[str]:
        """The runs that ended since the last call (each reported once)."""
        ...

    def ready(self) -> bool:
        """Connected, idle, still and re-zeroed: a run may start."""
        ...

    def unavailable(self) -> str | None:
        """Why nobody can drive the rig now (silent, out of service), or ``None``."""
        ...

    def stop_for_queue(self, run_id: str, reason: str) -> None: ...


@dataclass(frozen=True)
class SeatSettings:
    """``rig``: the queue's key in the store; ``every`` (s): how often the keeper looks;
    ``orphan`` (s): how long a seated run may take to reach the engine; ``out_after`` (s):
    how long a problem lasts before the rig goes out of service."""

    rig: str = "rig"
    policy: QueuePolicy = field(default_factory=QueuePolicy)
    every: float = 0.1
    orphan: float = 15.0
    out_after: float = 5.0


class SeatKeeper:
    def __init__(
        self,
        store: RigQueueStore,
        engine: SeatedEngine,
        settings: SeatSettings,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.store = store
        self.engine = engine
        self.settings = settings
        self.clock = clock
        self.queue = RigQueue()
        self._problem_since: float | None = None
        self._closing = threading.Event()
        self._thread = threading.Thread(target=self._run, name="elab-rig-seat", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._closing.set()
        self._thread.join(5.0)

    def _run(self) -> None:
        while not self._closing.wait(self.settings.every):
            try:
                self.check()
            except ElabError as exc:  # the store failing: try again next time
                log.warning("rig queue: %s", exc)

    def check(self) -> RigQueue:
        """One comparison of the engine with the queue, and what it calls for."""
        s, now = self.settings, self.clock()
        q = self.store.rig_queue(s.rig, s.policy, now)
        for run_id in self.engine.ended_runs():
            q = self._apply(RunEnded(run_id), now)
        current = self.engine.current_run()
        if current is not None and current != q.running:
            self.engine.stop_for_queue(current, _why(q, current))
        seat = q.seat
        if (
            q.running is not None
            and seat is not None
            and q.running not in (current, self.engine.taking())
            and now - seat.since > s.orphan
        ):
            log.warning("rig queue: run %s never reached the rig; its seat moves on", q.running)
            q = self._apply(RunEnded(q.running), now)
        q = self._service(q, now)
        if q.settling and not q.out_of_service and self.engine.ready():
            q = self._apply(Settled(), now)
        self.queue = q
        return q

    def _service(self, q: RigQueue, now: float) -> RigQueue:
        problem = self.engine.unavailable()
        if problem is None:
            self._problem_since = None
            return self._apply(SetService(""), now) if q.out_of_service else q
        if self._problem_since is None:
            self._problem_since = now
        if now - self._problem_since < self.settings.out_after or q.out_of_service == problem:
            return q
        log.error("rig out of service: %s", problem)
        return self._apply(SetService(problem), now)

    def _apply(self, op: QueueOp, now: float) -> RigQueue:
        s = self.settings
        return self.store.apply_rig(s.rig, op, s.policy, now).queue


def _why(q: RigQueue, run_id: str) -> str:
    seat = q.seat
    if q.out_of_service:
        return f"the rig went out of service ({q.out_of_service})"
    if seat is None:
        return "its driver's slot on the rig ended"
    if seat.took_over:
        return f"an instructor ({seat.user}) took the rig over"
    return "its run no longer holds the rig (the slot ended or an emergency stop)"
