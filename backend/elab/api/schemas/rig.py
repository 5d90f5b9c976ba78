"""The rig's queue: who drives it, your place and wait, and what instructors may do."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from elab.api.schemas.base import Model
from elab.api.schemas.health import RigInfo


class RigPlace(Model):
    """Where the caller stands in the rig's queue."""

    place: int | None = Field(description="1: the head (the driver once seated); null: not queued")
    wait_s: float | None = Field(
        description="estimated s until the caller is seated (0: driving; null: not queued, "
        "or the rig is out of service)"
    )
    driving: bool = Field(description="the caller holds the rig's seat")
    arm_by: float | None = Field(
        description="unix s by which the caller, seated, must arm the rig or lose the turn"
    )


class RigQueueInfo(Model):
    """The rig's queue now (``GET /rig``; every queue operation answers with it)."""

    rig: RigInfo  # the rig itself: connection, identity, loop latency
    in_service: bool = Field(description="someone may drive it (out of service: nobody)")
    out_of_service: str | None = Field(description="why nobody may drive it")
    settling: bool = Field(
        description="a run ended: 0 V until the link is still, then it re-zeroes; the next "
        "run starts after"
    )
    driver: str | None = Field(description="who holds the seat (a display name)")
    phase: Literal["seated", "armed", "running"] | None = Field(
        description="seated: must arm within the grace; armed: may start a run; running"
    )
    run_id: str | None = Field(description="the run on the rig now")
    slot_ends_at: float | None = Field(description="unix s the driver's slot ends")
    taken_over: bool = Field(description="an instructor took the rig over")
    waiting: int = Field(description="users in the queue behind the driver")
    slot_s: float = Field(description="a driver's turn (ELAB_RIG_SLOT)")
    grace_s: float = Field(description="how long a seated driver may take to arm (ELAB_RIG_GRACE)")
    you: RigPlace
    now: float = Field(description="the server's unix s these times are relative to")


class RigExtend(Model):
    seconds: float = Field(gt=0, le=86400, description="s added to the driver's slot")
