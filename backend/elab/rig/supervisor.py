"""The trusted supervisor: between the controller's requested voltage and the amplifier.

Pure and clockless: the host loop feeds it each sample (index ``k``, time ``t`` in s, the
measured θ, α in rad and θ̇ in rad/s, the requested ``u`` in V, and whether the controller
answered late) and sends the voltage it returns. Per sample, in this order:

1. a rig fault (its watchdog or status bit) trips at once;
2. the run's maximum duration and the user's inactivity (no :meth:`Supervisor.touch` for
   ``inactivity`` s) trip;
3. |θ|, |θ̇| and |α| beyond their limits trip after ``n_bad`` samples in a row each (a good
   sample resets that count; practable's penduino trips after 10);
4. a late (or non-finite) answer holds the last voltage; ``n_late`` in a row trip;
5. the voltage is clipped to ±``u_max`` and its change per sample to ``slew · Ts``.

A trip is latched: 0 V from that sample on, whatever arrives, until :meth:`reset`.
:meth:`estop` and :meth:`disconnect` trip at once. See ``reference/remote-labs.md``
(practable's supervisor MCU and penduino firmware) for where the numbers come from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from enum import StrEnum

from elab.errors import InvalidInput


@dataclass(frozen=True, kw_only=True)
class SafetyLimits:
    """Limits for the rotary flexible link (SI units).

    ``u_max`` (V): the amplifier's command clip; ``slew`` (V/s): fastest voltage change;
    ``theta_max`` (rad, 120°): the servo's arc before the link meets the base's stops;
    ``theta_dot_max`` (rad/s): servo speed; ``alpha_max`` (rad, 15°): the link's deflection
    the strain gauge may see without bending the blade for good; ``n_bad``: bad samples in a
    row before a trip; ``n_late``: late controller answers in a row before a trip, except
    in a run's first ``n_start`` samples (a fresh controller process's first answers are
    slow: they hold the voltage, which starts at 0 V, and trip only if still late after);
    ``inactivity`` (s): practable's 90 s after the last command; ``duration`` (s): longest
    run.
    """

    u_max: float = 10.0
    slew: float = 1000.0
    theta_max: float = math.radians(120.0)
    theta_dot_max: float = 30.0
    alpha_max: float = math.radians(15.0)
    n_bad: int = 10
    n_late: int = 5
    n_start: int = 50
    inactivity: float = 90.0
    duration: float = 600.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name.startswith("n_"):
                if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                    raise InvalidInput(f"safety.{f.name}", value, "a whole number ≥ 1")
            elif not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise InvalidInput(f"safety.{f.name}", value, "a finite number > 0")


class TripReason(StrEnum):
    ANGLE = "angle"
    SPEED = "speed"
    DEFLECTION = "deflection"
    DEADLINE = "deadline"
    ESTOP = "estop"
    DISCONNECT = "disconnect"
    INACTIVITY = "inactivity"
    DURATION = "duration"
    RIG_FAULT = "rig_fault"


@dataclass(frozen=True)
class Trip:
    """Why the supervisor cut the voltage: at sample ``k``, time ``t`` (s), the offending
    ``value`` against its ``limit`` (in the units the message states)."""

    reason: TripReason
    k: int
    t: float
    value: float
    limit: float
    message: str


@dataclass(frozen=True)
class Decision:
    """The voltage to send (V), and the trip in force if any (then ``u_applied`` is 0)."""

    u_applied: float
    trip: Trip | None = None


# measured quantity: (reason, name in messages, unit, SafetyLimits field)
_WATCHED = (
    (TripReason.ANGLE, "θ", "rad", "theta_max"),
    (TripReason.SPEED, "θ̇", "rad/s", "theta_dot_max"),
    (TripReason.DEFLECTION, "α", "rad", "alpha_max"),
)


class Supervisor:
    """One run's supervisor at sample time ``Ts`` (s). Not thread-safe: the host loop owns
    it."""

    def __init__(self, limits: SafetyLimits, Ts: float) -> None:
        if not (math.isfinite(Ts) and Ts > 0):
            raise InvalidInput("Ts", Ts, "a finite sample time > 0 s")
        self.limits = limits
        self.Ts = Ts
        self.reset()

    def reset(self) -> None:
        """Clear a trip and every count: the next sample starts a new run from 0 V."""
        self.trip: Trip | None = None
        self._u = 0.0
        self._bad = dict.fromkeys(TripReason, 0)
        self._late = 0
        self._t0: float | None = None
        self._active: float | None = None

    def touch(self, t: float) -> None:
        """The user acted at ``t`` (s): a command, a parameter change, a heartbeat."""
        self._active = t

    def estop(self, k: int, t: float) -> Decision:
        return self._trip(Trip(TripReason.ESTOP, k, t, 0.0, 0.0, "emergency stop pressed"))

    def disconnect(self, k: int, t: float) -> Decision:
        message = "the controller or the user's connection was lost"
        return self._trip(Trip(TripReason.DISCONNECT, k, t, 0.0, 0.0, message))

    def step(
        self,
        k: int,
        t: float,
        theta: float,
        alpha: float,
        theta_dot: float,
        u_requested: float,
        late: bool,
        *,
        fault: bool = False,
    ) -> Decision:
        """The voltage (V) to apply for sample ``k`` at time ``t`` (s)."""
        if self.trip is not None:
            return Decision(0.0, self.trip)
        if self._t0 is None:
            self._t0 = t
        if self._active is None:
            self._active = t
        trip = self._check(k, t, fault, (theta, theta_dot, alpha))
        if trip is None:
            trip = self._deadline(k, t, late or not math.isfinite(u_requested))
        if trip is not None:
            return self._trip(trip)
        target = self._u if self._late else u_requested
        lim = self.limits
        target = min(max(target, -lim.u_max), lim.u_max)
        step = lim.slew * self.Ts
        self._u = min(max(target, self._u - step), self._u + step)
        return Decision(self._u)

    def _check(self, k: int, t: float, fault: bool, measured: tuple[float, ...]) -> Trip | None:
        lim = self.limits
        if fault:
            message = "the rig reported a fault (its watchdog or status word)"
            return Trip(TripReason.RIG_FAULT, k, t, 1.0, 0.0, message)
        assert self._t0 is not None and self._active is not None
        if t - self._t0 > lim.duration:
            message = f"the run lasted {t - self._t0:g} s, longer than {lim.duration:g} s"
            return Trip(TripReason.DURATION, k, t, t - self._t0, lim.duration, message)
        if t - self._active > lim.inactivity:
            idle = t - self._active
            message = f"no command from the user for {idle:g} s (limit {lim.inactivity:g} s)"
            return Trip(TripReason.INACTIVITY, k, t, idle, lim.inactivity, message)
        for (reason, name, unit, field), value in zip(_WATCHED, measured, strict=True):
            limit = float(getattr(lim, field))
            bad = not abs(value) <= limit  # a NaN reading is bad too
            self._bad[reason] = self._bad[reason] + 1 if bad else 0
            if self._bad[reason] >= lim.n_bad:
                message = (
                    f"{name} = {value:.4g} {unit} beyond ±{limit:.4g} {unit} "
                    f"for {lim.n_bad} samples in a row"
                )
                return Trip(reason, k, t, value, limit, message)
        return None

    def _deadline(self, k: int, t: float, late: bool) -> Trip | None:
        self._late = self._late + 1 if late else 0
        if self._late < self.limits.n_late or k < self.limits.n_start:
            return None
        message = (
            f"the controller missed its deadline {self._late} samples in a row "
            f"(limit {self.limits.n_late})"
        )
        return Trip(
            TripReason.DEADLINE, k, t, float(self._late), float(self.limits.n_late), message
        )

    def _trip(self, trip: Trip) -> Decision:
        if self.trip is None:
            self.trip = trip
            self._u = 0.0
        return Decision(0.0, self.trip)
