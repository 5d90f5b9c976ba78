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
the queue's state decides. This package sits below both :mod:`elab.store` (which applies an
operation inside one write transaction, so one driver at a time is guaranteed by the store)
and :mod:`elab.rig` (whose host loop follows the seat), as :mod:`elab.lifecycle` does for
runs. Times are in seconds on one clock the caller chooses (unix seconds in the server).
"""

from elab.rig_queue.ops import (
    Arm,
    Clear,
    EStop,
    Extend,
    Join,
    Leave,
    QueueOp,
    RunEnded,
    SetService,
    Settled,
    Start,
    Stop,
    TakeOver,
    Tick,
)
from elab.rig_queue.rules import advance, apply
from elab.rig_queue.state import Phase, QueueChange, QueuePolicy, RigQueue, Seat

__all__ = [
    "Arm",
    "Clear",
    "EStop",
    "Extend",
    "Join",
    "Leave",
    "Phase",
    "QueueChange",
    "QueueOp",
    "QueuePolicy",
    "RigQueue",
    "RunEnded",
    "Seat",
    "SetService",
    "Settled",
    "Start",
    "Stop",
    "TakeOver",
    "Tick",
    "advance",
    "apply",
]
