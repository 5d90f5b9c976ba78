"""The trial a controller passes before it may drive the rig: the run as the rig would run
it, on the nonlinear flexible link (:mod:`elab.plants.flexible_link_nonlinear`) of several
rigs drawn across the hardware's spread (:func:`elab.rig.hardware.draw_rig_parameters`:
friction, dead zone, stiffness, motor gain…), each through the same trusted
:class:`~elab.rig.supervisor.Supervisor` and the same controller step as the host loop
(:func:`~elab.engines.riglaw.law_for`; a Python controller in its sandbox). A law that
trips the supervisor on any of them (the angle or deflection limits, speed, overflow,
answers too late) does not get the rig; the answer says which rig, what and when.

The real rig's own parameters are hidden and are not among those drawn here: the trial
asks "is this controller safe on *a* rig like ours", not "on this one". Each sample is
one classical Runge–Kutta step of the sample time with the voltage held (the plant's
slowest time constant is tens of ms; the emulator's 0.25 ms substeps agree to well
within the limits' margins), with θ read through the encoder's quantisation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from elab.controllers.sandbox import ControllerFailed
from elab.engines.riglaw import compile_for_rig, law_for
from elab.engines.settings import TRIAL_S, CodeSettings
from elab.plants.flexible_link_nonlinear import State, rk4_floats
from elab.rig.hardware import COUNTS_PER_REV, draw_rig_parameters
from elab.rig.supervisor import SafetyLimits, Supervisor, Trip
from elab.sim.spec import CompiledRun, RunSpec

#: The rigs a trial draws (seeds of :func:`draw_rig_parameters`; the served rig's own
#: seed is not one of them)
TRIAL_RIGS = (9001, 9002, 9003, 9004, 9005)
#: s a Python controller's step may compute in a trial, ten in a row before it fails
#: (the rig's own deadline is the supervisor's; a trial's worker may share a busy CPU)
TRIAL_DEADLINE = 5e-3


@dataclass(frozen=True)
class RigOutcome:
    """One drawn rig: the supervisor's trip (``None``: none), the peaks of |θ|, |α| (rad)
    and |u| (V) up to it, and why a Python controller failed (it raised, never answered
    or was too slow by its own compute time), if it did."""

    rig: int
    trip: Trip | None
    peak_theta: float
    peak_alpha: float
    peak_u: float
    failed: str | None = None


@dataclass(frozen=True)
class RigTrial:
    """The outcome on each rig tried (none when the reference alone rules the run out),
    the s tried of each, and the largest |reference| of the whole run (rad) against the
    supervisor's angle limit."""

    outcomes: tuple[RigOutcome, ...]
    duration: float
    reach: float = 0.0
    theta_max: float = math.inf

    @property
    def passed(self) -> bool:
        return self.problem() is None

    def problem(self) -> str | None:
        """Why the controller may not drive the rig (``None``: it may)."""
        if self.reach > self.theta_max or not self.outcomes:
            return (
                f"its reference reaches {math.degrees(self.reach):.4g}°, beyond the rig's "
                f"±{math.degrees(self.theta_max):.4g}° (the supervisor's angle limit)"
            )
        failed = [o for o in self.outcomes if o.trip is not None or o.failed is not None]
        if not failed:
            return None
        first = failed[0]
        what = "the supervisor trips" if first.trip is not None else "the controller fails"
        why = (
            f"{first.trip.message} at t = {first.trip.t:.3g} s ({first.trip.reason})"
            if first.trip is not None
            else str(first.failed)
        )
        return (
            f"in a trial on the nonlinear link of {len(self.outcomes)} rigs drawn across "
            f"the hardware's spread, {what} on {len(failed)}: on rig {first.rig}, {why}"
        )


def rig_trial(
    spec: RunSpec,
    limits: SafetyLimits | None = None,
    rigs: tuple[int, ...] = TRIAL_RIGS,
    duration: float = TRIAL_S,
) -> RigTrial:
    """Try ``spec``'s controller, reference and excitation on each of ``rigs`` for the
    run's first ``duration`` s, from rest at zero (where the rig starts after its
    re-zero)."""
    limits = limits or SafetyLimits()
    tried = min(spec.duration, duration)
    reach = _reach(compile_for_rig(spec))
    if reach > limits.theta_max:  # past the trial's end too: nothing to try
        return RigTrial((), tried, reach, limits.theta_max)
    run = compile_for_rig(replace(spec, duration=tried))
    code = CodeSettings(deadline=TRIAL_DEADLINE)
    outcomes = []
    for i, seed in enumerate(rigs, start=1):
        outcomes.append(_try(run, seed, i, limits, code))
    return RigTrial(tuple(outcomes), tried, reach, limits.theta_max)


def _reach(run: CompiledRun, chunk: int = 100_000) -> float:
    """The largest |reference| over the whole run (rad)."""
    peak = 0.0
    for k in range(0, run.n_samples, chunk):
        r = run.exogenous(k, min(chunk, run.n_samples - k))[:, 0]
        peak = max(peak, float(np.max(np.abs(r))))
    return peak


def _try(
    run: CompiledRun, seed: int, i: int, limits: SafetyLimits, code: CodeSettings
) -> RigOutcome:
    """One rig; a Python controller that raises ends the trial with its error."""
    p = draw_rig_parameters(seed).plant
    law = law_for(run, code, trial=True)
    supervisor = Supervisor(limits, run.Ts)
    Ts, n = run.Ts, run.n_samples
    exo = run.exogenous(0, n)
    quantum = 2 * math.pi / COUNTS_PER_REV
    x: State = (0.0, 0.0, 0.0, 0.0)
    u = 0.0
    peaks = [0.0, 0.0, 0.0]
    trip = failed = None
    try:
        for k in range(n):
            theta = math.floor(x[0] / quantum) * quantum  # the encoder's count
            r, e = float(exo[k, 0]), float(exo[k, 1])
            try:
                u_req, late = law.u(k * Ts, r, e, theta, x[1])
            except ControllerFailed as exc:
                failed = str(exc)
                break
            decision = supervisor.step(k, k * Ts, theta, x[1], x[2], u_req, late)
            if decision.trip is not None:
                trip = decision.trip
                break
            u = decision.u_applied
            peaks = [max(peaks[0], abs(x[0])), max(peaks[1], abs(x[1])), max(peaks[2], abs(u))]
            x = rk4_floats(x, u, Ts, p)
    finally:
        law.close()
    return RigOutcome(i, trip, peaks[0], peaks[1], peaks[2], failed)
