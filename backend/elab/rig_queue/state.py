"""The state of a rig's queue: its policy, the seat, the queue, and what an operation
changed (times in s on the caller's clock)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from elab.errors import InvalidInput


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

    @property
    def running(self) -> str | None:
        """The one run that may be on the rig now. The rig engine compares its run with
        this at every check (level-triggered), so a stop that no caller acted on (a crash
        between the commit and the stop) still happens."""
        s = self.seat
        return s.run_id if s is not None and s.phase is Phase.RUNNING else None

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


@dataclass(frozen=True)
class QueueChange:
    """The queue after an operation, and the run the caller must stop now (the driver lost
    the seat, stopped or was taken over), if any: a prompt for this caller; the rig engine
    relies on :attr:`RigQueue.running` instead."""

    queue: RigQueue
    stop_run: str | None = None
