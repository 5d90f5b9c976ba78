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
import math
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TypeVar

from elab.access import Identity, display_name
from elab.engines.base import RunOrder
from elab.engines.riglaw import compile_for_rig
from elab.errors import ElabError, Forbidden, InvalidInput, Unavailable
from elab.rig.estop import send_estop
from elab.rig_queue import (
    Arm,
    Clear,
    EStop,
    Extend,
    Join,
    Leave,
    Phase,
    QueueOp,
    QueuePolicy,
    RigQueue,
    RunEnded,
    Start,
    TakeOver,
)
from elab.store.base import RigQueueStore

T = TypeVar("T")
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
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.store = store
        self.rig = rig
        self.policy = policy
        self.estop_address = estop
        self.clock = clock

    async def view(self, who: Identity, q: RigQueue | None = None) -> DeskView:
        now = self.clock()
        if q is None:
            q = await asyncio.to_thread(self.store.rig_queue, self.rig, self.policy, now)
        place = q.place(who.id) if who.id else None
        you = Place(place, q.wait(who.id, self.policy, now) if place else None, q.driver == who.id)
        driver = display_name(q.driver) if q.driver else None
        return DeskView(q, self.policy, driver, you, now)

    async def join(self, who: Identity) -> DeskView:
        return await self._apply(Join(_someone(who, "join the rig's queue")), who)

    async def leave(self, who: Identity) -> DeskView:
        return await self._apply(Leave(_someone(who, "leave the rig's queue")), who)

    async def arm(self, who: Identity) -> DeskView:
        return await self._apply(Arm(_someone(who, "arm the rig")), who)

    async def take_over(self, who: Identity) -> DeskView:
        return await self._apply(TakeOver(_instructor(who, "take the rig over")), who)

    async def extend(self, who: Identity, seconds: float) -> DeskView:
        _instructor(who, "extend a slot on the rig")
        if not (math.isfinite(seconds) and 0 < seconds <= MAX_EXTEND):
            raise InvalidInput("seconds", seconds, f"a time in (0, {MAX_EXTEND:g}] s")
        return await self._apply(Extend(seconds), who)

    async def clear(self, who: Identity) -> DeskView:
        _instructor(who, "clear the rig's queue")
        return await self._apply(Clear(), who)

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
        view = await self._apply(EStop(who.id), who)
        if sent is not None:  # the queue stopped the run; the engine's own path is down
            raise sent
        return view

    async def seated(self, who: Identity, order: RunOrder, start: Callable[[], Awaitable[T]]) -> T:
        """``start()`` (the engine adding run ``order``) once the caller's armed seat has
        taken the run: :class:`~elab.errors.Conflict` unless ``who`` drives the rig and
        armed it. A law the rig cannot run is refused before it takes the seat; a run its
        engine refuses all the same gives the seat back (the driver arms again)."""
        await asyncio.to_thread(compile_for_rig, order.spec)  # InvalidInput: as the engine's
        run_id = order.id
        await self._apply(Start(_someone(who, "drive the rig"), run_id), who)
        try:
            return await start()
        except BaseException:
            with contextlib.suppress(ElabError):
                await self._apply(RunEnded(run_id), None)
            raise

    async def _apply(self, op: QueueOp, who: Identity | None) -> DeskView:
        change = await asyncio.to_thread(
            self.store.apply_rig, self.rig, op, self.policy, self.clock()
        )
        return await self.view(who or Identity(""), change.queue)


def phase_of(q: RigQueue) -> Phase | None:
    return q.seat.phase if q.seat is not None else None


def _someone(who: Identity, action: str) -> str:
    if not who.id:
        raise Forbidden(f"to {action}, open the lab in a browser or send an API token first")
    return who.id


def _instructor(who: Identity, action: str) -> str:
    if not who.instructor:
        raise Forbidden(f"only an instructor may {action} (sign in first)")
    return who.id
