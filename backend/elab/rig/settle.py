"""After a run, before the next user: stop → settle → re-zero (a pure state machine).

The host loop sends 0 V throughout and feeds :func:`settle_step` each sample's θ̇ and α̇
(rad/s) and time ``t`` (s). Once both stay under their thresholds for ``still_for`` s the
rig asks for a re-zero (encoders and strain gauge; practable's penduino waits for 100
equal readings before it zeroes); when the loop reports it done (:func:`rezeroed`) the rig
is ready for the next user (:class:`elab.rig_queue.Settled`). Not ready within ``timeout``
s of the start: out of service, for an operator to look at (the queue's
:class:`elab.rig_queue.SetService`).

::

    settling ─(still for still_for s)→ rezero ─rezeroed→ ready
    settling | rezero ─(timeout)→ out_of_service
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from enum import StrEnum

from elab.errors import Conflict, InvalidInput


@dataclass(frozen=True, kw_only=True)
class SettleLimits:
    """``theta_dot_still``, ``alpha_dot_still`` (rad/s): "still" thresholds (the link's
    vibration decays within a few seconds at 0 V); ``still_for`` (s): how long it must stay
    still; ``timeout`` (s): the longest a settle may take."""

    theta_dot_still: float = 0.05
    alpha_dot_still: float = 0.2
    still_for: float = 2.0
    timeout: float = 60.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InvalidInput(f"settle.{f.name}", value, "a finite number > 0")
        if self.still_for >= self.timeout:
            raise InvalidInput("settle.still_for", self.still_for, f"< timeout {self.timeout} s")


class SettlePhase(StrEnum):
    SETTLING = "settling"  # 0 V, waiting until still
    REZERO = "rezero"  # still: the loop should zero the encoders and the gauge now
    READY = "ready"  # the next user may start
    OUT_OF_SERVICE = "out_of_service"  # did not settle in time


@dataclass(frozen=True)
class Settle:
    """``started`` (s): when the settle began; ``still_since`` (s): the start of the
    current still stretch, ``None`` while moving; ``message``: why out of service."""

    phase: SettlePhase
    started: float
    still_since: float | None = None
    message: str = ""


def begin_settle(t: float) -> Settle:
    return Settle(SettlePhase.SETTLING, t)


def settle_step(
    s: Settle, limits: SettleLimits, t: float, theta_dot: float, alpha_dot: float
) -> Settle:
    """The settle after one more sample at ``t``; READY and OUT_OF_SERVICE stay as they
    are."""
    if s.phase in (SettlePhase.READY, SettlePhase.OUT_OF_SERVICE):
        return s
    if t - s.started > limits.timeout:
        message = (
            f"the rig did not settle and re-zero within {limits.timeout:g} s "
            f"(phase {s.phase.value}); an operator should check it"
        )
        return replace(s, phase=SettlePhase.OUT_OF_SERVICE, message=message)
    if s.phase is SettlePhase.REZERO:
        return s
    still = abs(theta_dot) <= limits.theta_dot_still and abs(alpha_dot) <= limits.alpha_dot_still
    if not still:
        return replace(s, still_since=None)
    since = t if s.still_since is None else s.still_since
    if t - since >= limits.still_for:
        return replace(s, phase=SettlePhase.REZERO, still_since=since)
    return replace(s, still_since=since)


def rezeroed(s: Settle) -> Settle:
    """The loop zeroed the encoders and the gauge: ready (:class:`Conflict` unless asked)."""
    if s.phase is not SettlePhase.REZERO:
        raise Conflict(f"the settle is {s.phase.value}: re-zero only when it asks for it")
    return replace(s, phase=SettlePhase.READY)
