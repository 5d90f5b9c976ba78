"""The rules: an operation applied to a queue at ``now``, or :class:`Conflict`."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import assert_never

from elab.errors import Conflict, InvalidInput
from elab.rig_queue import ops
from elab.rig_queue.state import Phase, QueueChange, QueuePolicy, RigQueue, Seat


def apply(q: RigQueue, op: ops.QueueOp, policy: QueuePolicy, now: float) -> QueueChange:
    """``q`` advanced to ``now``, then changed by ``op``; :class:`Conflict` if ``op`` is not
    allowed in that state (nothing changes then)."""
    before = q
    q = advance(q, policy, now)
    match op:
        case ops.Join(user):
            q = _join(q, user)
        case ops.Leave(user):
            q = _remove(_member(q, user), user)
        case ops.Arm(user):
            q = _arm(_driving(q, user), now)
        case ops.Start(user, run_id):
            q = _start(_driving(q, user), run_id, now)
        case ops.Stop(user):
            q = _end_run(_running(_driving(q, user)), now)
        case ops.EStop():
            q = _end_run(q, now) if q.seat and q.seat.phase is Phase.RUNNING else q
        case ops.RunEnded(run_id):
            q = _end_run(q, now) if q.seat and q.seat.run_id == run_id else q
        case ops.TakeOver(user):
            q = _take_over(q, user, policy, now)
        case ops.Extend(seconds):
            q = _extend(q, seconds)
        case ops.Clear():
            q = replace(q, users=q.users[:1] if q.seat else ())
        case ops.SetService(reason):
            q = _set_service(q, reason)
        case ops.Settled():
            q = replace(q, settling=False)
        case ops.Tick():
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
    return before.running if before.running != after.running else None


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
