"""The rig queue: one rig, many users, one driver at a time (pure rules, no I/O, no clock).

Users join a FIFO queue; the head of the queue gets the *seat* for a slot (``slot`` s) and
must *arm* within a no-show grace (``grace`` s) or loses its turn. Armed, the driver starts a
run; the run ends (stop, finish, e-stop, trip) and the driver, still seated, may arm again
until the slot ends. Between runs the rig *settles* (0 V, still, re-zeroed): nobody starts
until the rig reports it settled. An instructor may take over (driving now, ahead of
everyone; a displaced student waits first in line, an instructor's take-over ends with its
seat), extend the slot or clear the waiting users. An out-of-service rig seats nobody.
Spectators are not in the queue.

::

    join → waiting ─(head, in service)→ seated ─arm→ armed ─start→ running
    running ─(stop | finish | e-stop | trip)→ seated (the rig settles)
    seated ─(grace passes)→ gone;  any seat ─(slot ends | leave)→ gone

Every operation is one :data:`QueueOp`; :func:`apply` advances time to ``now`` (expiring
slots and no-shows, seating the head) and then applies the operation, raising
:class:`~elab.errors.Conflict` for an illegal one. Who may send which operation (only
instructors take over, extend or clear) is the API's decision; the rules check only what
the queue's state decides. This module sits below both :mod:`elab.store` (which applies an
operation inside one write transaction, so one driver at a time is guaranteed by the store)
and :mod:`elab.rig` (whose host loop follows the seat), as :mod:`elab.lifecycle` does for
runs. Times are in seconds on one clock the caller chooses (unix seconds in the server).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import StrEnum
from typing import assert_never

from elab.errors import Conflict, InvalidInput


@dataclass(frozen=True)
class QueuePolicy:
    """``slot`` (s): a driver's turn; ``grace`` (s): how long a newly seated driver may take
    to arm before losing the turn."""

    slot: float = 300.0
    grace: float = 60.0

    def __post_init__(self) -> None:
        for name, value in (("slot", self.slot), ("grace", self.grace)):
            if not (math.isfinite(value) and value > 0):
                raise InvalidInput(f"rig_queue.{name}", value, "a finite time > 0 s")
        if self.grace > self.slot:
            raise InvalidInput("rig_queue.grace", self.grace, f"at most the slot, {self.slot} s")


class Phase(StrEnum):
    SEATED = "seated"  # the driver must arm within the grace after ``since``
    ARMED = "armed"  # may start a run (once the rig has settled)
    RUNNING = "running"  # a run of the driver's is on the rig


@dataclass(frozen=True)
class Seat:
    """Who drives the rig: ``since`` the phase began, ``until`` the slot ends (s);
    ``run_id`` the run on the rig while running; ``took_over``: an instructor's seat."""

    user: str
    phase: Phase
    since: float
    until: float
    run_id: str | None = None
    took_over: bool = False


@dataclass(frozen=True)
class RigQueue:
    """The queue of one rig. ``users``: in order, places 1..n; the seat, if any, is the
    head's. ``settling``: a run ended and the rig has not yet reported itself still and
    re-zeroed. ``out_of_service``: why nobody may drive (empty: in service)."""

    users: tuple[str, ...] = ()
    seat: Seat | None = None
    settling: bool = False
    out_of_service: str = ""

    @property
    def driver(self) -> str | None:
        return self.seat.user if self.seat else None

    def place(self, user: str) -> int | None:
        """1 for the head (the driver when seated), ``None`` for someone not in the queue."""
        return self.users.index(user) + 1 if user in self.users else None

    def wait(self, user: str, policy: QueuePolicy, now: float) -> float | None:
        """Estimated seconds until ``user`` is seated: 0 for the driver; the rest of the
        current slot plus a full slot per user ahead; ``None`` if unknown (not queued, or
        the rig is out of service)."""
        place = self.place(user)
        if place is None or self.out_of_service:
            return None
        if self.seat is not None and self.seat.user == user:
            return 0.0
        rest = max(0.0, self.seat.until - now) if self.seat else 0.0
        ahead = place - 1 - (1 if self.seat else 0)
        return rest + ahead * policy.slot


# -- operations --------------------------------------------------------------------------
@dataclass(frozen=True)
class Join:
    user: str


@dataclass(frozen=True)
class Leave:
    user: str


@dataclass(frozen=True)
class Arm:
    user: str


@dataclass(frozen=True)
class Start:
    user: str
    run_id: str


@dataclass(frozen=True)
class Stop:
    """The driver stops its run."""

    user: str


@dataclass(frozen=True)
class EStop:
    """Emergency stop: ends any run on the rig, never refused (the API decides who may)."""

    user: str


@dataclass(frozen=True)
class RunEnded:
    """The engine reports that run ``run_id`` ended (finished, tripped, failed)."""

    run_id: str


@dataclass(frozen=True)
class TakeOver:
    """An instructor drives now; a running run is stopped."""

    user: str


@dataclass(frozen=True)
class Extend:
    seconds: float


@dataclass(frozen=True)
class Clear:
    """Everyone waiting leaves the queue (the driver keeps the seat)."""


@dataclass(frozen=True)
class SetService:
    """The health monitor or an operator: out of service for ``reason`` (empty: back in
    service, which also vouches that the rig is settled)."""

    reason: str


@dataclass(frozen=True)
class Settled:
    """The rig is still and re-zeroed after a run: the next run may start."""


@dataclass(frozen=True)
class Tick:
    """Only let time pass (expire slots and no-shows, seat the next user)."""


QueueOp = (Join | Leave | Arm | Start | Stop | EStop | RunEnded | TakeOver | Extend | Clear) | (
    SetService | Settled | Tick
)


@dataclass(frozen=True)
class QueueChange:
    """The queue after an operation, and the run the caller must stop now (the driver lost
    the seat, stopped or was taken over), if any."""

    queue: RigQueue
    stop_run: str | None = None


def apply(q: RigQueue, op: QueueOp, policy: QueuePolicy, now: float) -> QueueChange:
    """``q`` advanced to ``now``, then changed by ``op``; :class:`Conflict` if ``op`` is not
    allowed in that state (nothing changes then)."""
    before = q
    q = advance(q, policy, now)
    match op:
        case Join(user):
            q = _join(q, user)
        case Leave(user):
            q = _remove(_member(q, user), user)
        case Arm(user):
            q = _arm(_driving(q, user), now)
        case Start(user, run_id):
            q = _start(_driving(q, user), run_id, now)
        case Stop(user):
            q = _end_run(_running(_driving(q, user)), now)
        case EStop():
            q = _end_run(q, now) if q.seat and q.seat.phase is Phase.RUNNING else q
        case RunEnded(run_id):
            q = _end_run(q, now) if q.seat and q.seat.run_id == run_id else q
        case TakeOver(user):
            q = _take_over(q, user, policy, now)
        case Extend(seconds):
            q = _extend(q, seconds)
        case Clear():
            q = replace(q, users=q.users[:1] if q.seat else ())
        case SetService(reason):
            q = _set_service(q, reason)
        case Settled():
            q = replace(q, settling=False)
        case Tick():
            pass
        case _:
            assert_never(op)
    q = advance(q, policy, now)
    return QueueChange(q, _stopped(before, q))


def advance(q: RigQueue, policy: QueuePolicy, now: float) -> RigQueue:
    """Time passes until ``now``: an ended slot or a no-show loses the seat (and its place),
    then the head of the queue is seated if the rig is in service."""
    s = q.seat
    if s is not None and (
        now >= s.until or (s.phase is Phase.SEATED and now >= s.since + policy.grace)
    ):
        q = _remove(q, s.user)
    if q.seat is None and q.users and not q.out_of_service:
        q = replace(q, seat=Seat(q.users[0], Phase.SEATED, now, now + policy.slot))
    return q


def _stopped(before: RigQueue, after: RigQueue) -> str | None:
    run = before.seat.run_id if before.seat and before.seat.phase is Phase.RUNNING else None
    still = after.seat is not None and after.seat.run_id == run
    return None if run is None or still else run


def _join(q: RigQueue, user: str) -> RigQueue:
    if user in q.users:
        raise Conflict(f"{user} is already in the rig queue at place {q.place(user)}")
    return replace(q, users=(*q.users, user))


def _member(q: RigQueue, user: str) -> RigQueue:
    if user not in q.users:
        raise Conflict(f"{user} is not in the rig queue (join it first)")
    return q


def _remove(q: RigQueue, user: str) -> RigQueue:
    """``user`` leaves the queue; if seated, the seat is free and a running run ends."""
    users = tuple(u for u in q.users if u != user)
    if q.seat is None or q.seat.user != user:
        return replace(q, users=users)
    return replace(q, users=users, seat=None, settling=q.settling or _is_running(q))


def _is_running(q: RigQueue) -> bool:
    return q.seat is not None and q.seat.phase is Phase.RUNNING


def _driving(q: RigQueue, user: str) -> RigQueue:
    if q.out_of_service:
        raise Conflict(f"the rig is out of service ({q.out_of_service}); nobody drives it")
    if q.seat is None or q.seat.user != user:
        place = q.place(user)
        where = f"your place in the queue is {place}" if place else "join the queue first"
        raise Conflict(f"{user}: you are not the driver of the rig; {where}")
    return q


def _arm(q: RigQueue, now: float) -> RigQueue:
    assert q.seat is not None
    if q.seat.phase is not Phase.SEATED:
        raise Conflict(f"the rig is already {q.seat.phase.value}: arm only when seated")
    return replace(q, seat=replace(q.seat, phase=Phase.ARMED, since=now))


def _start(q: RigQueue, run_id: str, now: float) -> RigQueue:
    assert q.seat is not None
    if q.seat.phase is not Phase.ARMED:
        raise Conflict(f"the rig is {q.seat.phase.value}: arm it before starting a run")
    if q.settling:
        raise Conflict("the rig is settling after the last run; start when it is ready")
    return replace(q, seat=replace(q.seat, phase=Phase.RUNNING, since=now, run_id=run_id))


def _running(q: RigQueue) -> RigQueue:
    if not _is_running(q):
        raise Conflict("no run of yours is on the rig: nothing to stop")
    return q


def _end_run(q: RigQueue, now: float) -> RigQueue:
    assert q.seat is not None
    seat = replace(q.seat, phase=Phase.SEATED, since=now, run_id=None)
    return replace(q, seat=seat, settling=True)


def _take_over(q: RigQueue, user: str, policy: QueuePolicy, now: float) -> RigQueue:
    if q.out_of_service:
        raise Conflict(f"the rig is out of service ({q.out_of_service}); nobody drives it")
    if q.seat is not None and q.seat.user == user:
        raise Conflict(f"{user} already drives the rig")
    settling = q.settling or _is_running(q)
    if q.seat is not None and q.seat.took_over:  # a take-over ends with its seat
        q = _remove(q, q.seat.user)
    seat = Seat(user, Phase.SEATED, now, now + policy.slot, took_over=True)
    users = (user, *(u for u in q.users if u != user))
    return replace(q, users=users, seat=seat, settling=settling)


def _extend(q: RigQueue, seconds: float) -> RigQueue:
    if not (math.isfinite(seconds) and seconds > 0):
        raise InvalidInput("extend.seconds", seconds, "a finite time > 0 s")
    if q.seat is None:
        raise Conflict("nobody drives the rig: there is no slot to extend")
    return replace(q, seat=replace(q.seat, until=q.seat.until + seconds))


def _set_service(q: RigQueue, reason: str) -> RigQueue:
    if not reason:
        return replace(q, out_of_service="", settling=False)
    if q.seat is not None and q.seat.took_over:  # a take-over ends with its seat
        q = _remove(q, q.seat.user)
    return replace(q, out_of_service=reason, seat=None, settling=q.settling or _is_running(q))
