"""The operations on a rig's queue: one frozen dataclass each, one union."""

from __future__ import annotations

from dataclasses import dataclass


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


#: Every operation on a rig's queue (dispatched once, in :func:`elab.rig_queue.rules.apply`).
QueueOp = (
    Join
    | Leave
    | Arm
    | Start
    | Stop
    | EStop
    | RunEnded
    | TakeOver
    | Extend
    | Clear
    | SetService
    | Settled
    | Tick
)
