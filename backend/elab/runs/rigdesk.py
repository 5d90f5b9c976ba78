"""The rig's front desk in the web process: who may do what with the rig's queue.

The queue's rules are :mod:`elab.rig_queue`'s and each change is one atomic store
operation (:class:`~elab.store.base.RigQueueStore`); the rig engine follows the queue on
its own (:mod:`elab.engines.rigseat`). The desk adds who may ask: anyone with an identity
joins, leaves, arms and drives in turn; only instructors take over, extend a slot or clear
the queue; the driver and instructors press the emergency stop, which goes to the rig
engine on its own socket (:mod:`elab.rig.estop`) as well as into the queue, so it stops the
motor whether or not this process is answering. A run in mode ``rig`` takes the seat
(:meth:`RigDesk.seat_run`) before the engine is asked to step it.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import math
import pickle
import time
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

from elab import rig_queue as rq
from elab.access import Identity, display_name
from elab.engines.base import RunOrder
from elab.engines.settings import TRIAL_S
from elab.errors import ElabError, Forbidden, InvalidInput, Unavailable
from elab.jobs import JobPool
from elab.laws import law_kind
from elab.rig.estop import send_estop
from elab.rig_queue import QueuePolicy, RigQueue
from elab.sim.spec import RunSpec
from elab.store.base import RigQueueStore

if TYPE_CHECKING:  # the rig's laws and trial step runs: imported where a run is tried
    from elab.engines.rigtrial import RigTrial

T = TypeVar("T")
PASSED_KEPT = 256  # passed rig trials remembered
MAX_EXTEND = 24 * 3600.0  # s an instructor may add to a slot at once


@dataclass(frozen=True)
class Place:
    """Where ``who`` stands: ``place`` 1 is the head (the driver once seated), ``None``
    outside the queue; ``wait`` the estimated s until seated (``None``: unknown)."""

    place: int | None
    wait: float | None
    driving: bool


@dataclass(frozen=True)
class DeskView:
    """The queue as one caller sees it (names for display, never others' ids)."""

    queue: RigQueue
    policy: QueuePolicy
    driver: str | None
    you: Place
    now: float


class RigDesk:
    def __init__(
        self,
        store: RigQueueStore,
        rig: str,
        policy: QueuePolicy,
        estop: str | None,
        trials: JobPool | None = None,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.store = store
        self.rig = rig
        self.policy = policy
        self.estop_address = estop
        self.trials = trials  # the worker pool rig trials run in (None: this process)
        self.clock = clock
        self._passed: OrderedDict[str, RigTrial] = OrderedDict()  # trials passed, by run

    async def view(self, who: Identity, q: RigQueue | None = None) -> DeskView:
        now = self.clock()
        if q is None:
            q = await asyncio.to_thread(self.store.rig_queue, self.rig, self.policy, now)
        place = q.place(who.id) if who.id else None
        you = Place(place, q.wait(who.id, self.policy, now) if place else None, q.driver == who.id)
        driver = display_name(q.driver) if q.driver else None
        return DeskView(q, self.policy, driver, you, now)

    async def join(self, who: Identity) -> DeskView:
        return await self._apply(rq.Join(_someone(who, "join the rig's queue")), who)

    async def leave(self, who: Identity) -> DeskView:
        return await self._apply(rq.Leave(_someone(who, "leave the rig's queue")), who)

    async def arm(self, who: Identity) -> DeskView:
        return await self._apply(rq.Arm(_someone(who, "arm the rig")), who)

    async def take_over(self, who: Identity) -> DeskView:
        return await self._apply(rq.TakeOver(_instructor(who, "take the rig over")), who)

    async def extend(self, who: Identity, seconds: float) -> DeskView:
        _instructor(who, "extend a slot on the rig")
        if not (math.isfinite(seconds) and 0 < seconds <= MAX_EXTEND):
            raise InvalidInput("seconds", seconds, f"a time in (0, {MAX_EXTEND:g}] s")
        return await self._apply(rq.Extend(seconds), who)

    async def clear(self, who: Identity) -> DeskView:
        _instructor(who, "clear the rig's queue")
        return await self._apply(rq.Clear(), who)

    async def emergency_stop(self, who: Identity) -> DeskView:
        """Stop the motor now: the rig engine hears it on its own socket (whatever this
        process does next), and the queue ends the seat's run."""
        q = await asyncio.to_thread(self.store.rig_queue, self.rig, self.policy, self.clock())
        if not who.instructor and (not who.id or q.driver != who.id):
            raise Forbidden(
                "only the rig's driver or an instructor may press its emergency stop "
                f"(the driver now: {display_name(q.driver) if q.driver else 'nobody'})"
            )
        sent: ElabError | None = None
        if self.estop_address is not None:
            try:
                await asyncio.to_thread(send_estop, self.estop_address, who.name)
            except Unavailable as exc:
                sent = exc
        view = await self._apply(rq.EStop(who.id), who)
        if sent is not None:  # the queue stopped the run; the engine's own path is down
            raise sent
        return view

    async def seated(self, who: Identity, order: RunOrder, start: Callable[[], Awaitable[T]]) -> T:
        """``start()`` (the engine adding run ``order``) once the caller's armed seat has
        taken the run: :class:`~elab.errors.Conflict` unless ``who`` drives the rig and
        armed it. A law the rig cannot run is refused before it takes the seat; a run its
        engine refuses all the same gives the seat back (the driver arms again)."""
        await self.validate(order.spec)
        run_id = order.id
        await self._apply(rq.Start(_someone(who, "drive the rig"), run_id), who)
        try:
            return await start()
        except BaseException:
            with contextlib.suppress(ElabError):
                await self._apply(rq.RunEnded(run_id), None)
            raise

    async def validate(self, spec: RunSpec) -> RigTrial:
        """The run's rig trial (:mod:`elab.engines.rigtrial`), passed, or
        :class:`~elab.errors.InvalidInput` naming ``controller`` and what tripped. A
        passed trial is remembered for the same controller, signals and duration."""
        key = _trial_key(spec)
        trial = self._passed.get(key)
        if trial is None:  # (a law the rig cannot run at all: the trial's InvalidInput)
            if self.trials is not None:
                trial = await self.trials.run(_trial, spec)
            else:
                trial = await asyncio.to_thread(_trial, spec)
        problem = trial.problem()
        if problem is not None:
            raise InvalidInput(
                "controller",
                law_kind(spec.law),
                "a controller that passes the rig trial: " + problem,
            )
        self._passed[key] = trial
        self._passed.move_to_end(key)
        while len(self._passed) > PASSED_KEPT:
            self._passed.popitem(last=False)
        return trial

    async def _apply(self, op: rq.QueueOp, who: Identity | None) -> DeskView:
        change = await asyncio.to_thread(
            self.store.apply_rig, self.rig, op, self.policy, self.clock()
        )
        return await self.view(who or Identity(""), change.queue)


def _trial(spec: RunSpec) -> RigTrial:
    """:func:`elab.engines.rigtrial.rig_trial`, named here: the web process hands it to a
    trial worker (which imported the trial's modules once: ``controllers.JOB_MODULES``)
    without importing them itself; they bring python-control and numba, seconds of
    imports (docs/architecture.md, start-up)."""
    from elab.engines.rigtrial import rig_trial

    return rig_trial(spec)


def _trial_key(spec: RunSpec) -> str:
    """What a trial depends on: the law, the signals, the sample time and limits, and
    the duration tried (pickled: numbers to the last bit)."""
    tried = (
        spec.plant.id,
        spec.law,
        spec.reference,
        spec.excitation,
        spec.excitation_at,
        spec.Ts,
        spec.u_max,
        spec.saturate,
        min(spec.duration, TRIAL_S),
    )
    return hashlib.sha256(pickle.dumps(tried)).hexdigest()


def phase_of(q: RigQueue) -> rq.Phase | None:
    return q.seat.phase if q.seat is not None else None


def _someone(who: Identity, action: str) -> str:
    if not who.id:
        raise Forbidden(f"to {action}, open the lab in a browser or send an API token first")
    return who.id


def _instructor(who: Identity, action: str) -> str:
    if not who.instructor:
        raise Forbidden(f"only an instructor may {action} (sign in first)")
    return who.id
