"""``/rig``: the rig's queue. Join it, see your place and wait, arm the rig when your turn
comes and start a run in mode ``rig`` (``POST /runs``); press the emergency stop; as an
instructor, take the rig over, extend the slot or clear the queue. Spectators need
nothing of this: they watch rig runs like any other."""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from starlette.requests import HTTPConnection, Request
from starlette.responses import Response

from elab.access import Identity
from elab.api import schemas as s
from elab.api.auth import identity
from elab.api.http import endpoint, ok, read_model
from elab.api.runs import manager, rig_model
from elab.api.state import lab
from elab.errors import NotFound
from elab.rig_queue import Phase
from elab.runs.rigdesk import DeskView, RigDesk


def rig_desk(conn: HTTPConnection) -> RigDesk:
    d = lab(conn).desk
    if d is None:
        raise NotFound("rig", "on this server (ELAB_RIG is none)")
    return d


def queue_info(request: Request, view: DeskView) -> s.RigQueueInfo:
    q, seat = view.queue, view.queue.seat
    rig = rig_model(manager(request).status().engines.get("rig"))
    assert rig is not None  # a desk is made only with a rig engine
    arm_by = None
    if seat is not None and view.you.driving and seat.phase is Phase.SEATED:
        arm_by = min(seat.since + view.policy.grace, seat.until)
    return s.RigQueueInfo(
        rig=rig,
        in_service=not q.out_of_service,
        out_of_service=q.out_of_service or None,
        settling=q.settling,
        driver=view.driver,
        phase=seat.phase.value if seat is not None else None,
        run_id=q.running,
        slot_ends_at=seat.until if seat is not None else None,
        taken_over=seat is not None and seat.took_over,
        waiting=max(0, len(q.users) - (1 if seat is not None else 0)),
        slot_s=view.policy.slot,
        grace_s=view.policy.grace,
        you=s.RigPlace(
            place=view.you.place, wait_s=view.you.wait, driving=view.you.driving, arm_by=arm_by
        ),
        now=view.now,
    )


ERRORS = (403, 404, 409, 422, 503)
#: what a queue operation does to the desk, as the caller
Act = Callable[[RigDesk, Identity], Awaitable[DeskView]]


@endpoint("GET", "/rig", response=s.RigQueueInfo, errors=(404,))
async def get_rig(request: Request) -> Response:
    """The rig's queue: who drives, your place and wait"""
    return ok(queue_info(request, await rig_desk(request).view(identity(request))))


def _queue_endpoint(method: str, path: str, name: str, act: Act, doc: str) -> None:
    """``method path`` (operation ``name``): ``act`` as the caller, answered with the
    queue; ``doc`` the summary, then the description."""

    async def handler(request: Request) -> Response:
        return ok(queue_info(request, await act(rig_desk(request), identity(request))))

    handler.__name__ = handler.__qualname__ = name
    handler.__doc__ = doc
    endpoint(method, path, response=s.RigQueueInfo, errors=ERRORS)(handler)


_queue_endpoint(
    "POST",
    "/rig/queue",
    "join_queue",
    RigDesk.join,
    """Join the rig's queue

    The head of the queue is seated for a slot of ``slot_s`` s and must arm within
    ``grace_s`` s or lose the turn; 409 if the caller is queued already.""",
)
_queue_endpoint(
    "DELETE", "/rig/queue", "leave_queue", RigDesk.leave,
    "Leave the rig's queue (a driver's run stops)",
)  # fmt: skip
_queue_endpoint(
    "POST",
    "/rig/arm",
    "arm_rig",
    RigDesk.arm,
    """Arm the rig (the driver): a run in mode rig may start

    Then ``POST /runs`` with ``mode: rig`` starts the run (409 while the rig settles after
    the last one). After each run the driver, still seated, arms again.""",
)
_queue_endpoint(
    "POST",
    "/rig/estop",
    "estop_rig",
    RigDesk.emergency_stop,
    """Emergency stop (the driver or an instructor)

    0 V and the amplifier disabled at the rig's next sample; the run ends ``stopped``. It
    goes to the rig engine on a socket of its own, so it works while this server's other
    paths are busy; ``elab rig-estop`` does the same from a shell.""",
)
_queue_endpoint(
    "POST",
    "/rig/takeover",
    "take_over_rig",
    RigDesk.take_over,
    """Take the rig over now (instructors)

    A running run stops; its driver waits first in line; the take-over ends with its
    slot.""",
)
_queue_endpoint(
    "POST", "/rig/clear", "clear_queue", RigDesk.clear,
    "Clear the waiting users (instructors)",
)  # fmt: skip


@endpoint(
    "POST", "/rig/extend", body=s.RigExtend, response=s.RigQueueInfo, errors=(*ERRORS, 413, 415)
)
async def extend_slot(request: Request) -> Response:
    """Extend the driver's slot (instructors)"""
    req = await read_model(request, s.RigExtend)
    return ok(queue_info(request, await rig_desk(request).extend(identity(request), req.seconds)))
