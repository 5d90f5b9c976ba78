"""The validation report of a controller on a plant's linear model: what a student sees
on upload and from ``elab check``, the same in both places.

- the closed-loop poles (python-control, on the continuous loop of
  :func:`elab.design.plant_loop.closed_loop`) and whether the loop is stable;
- the stability margins of the loop broken at the plant input;
- the peak control voltage for a step of the plant's default reference amplitude,
  against the actuator limit;
- the sample time against the closed loop's fastest pole, and a discrete controller's
  own sample time against the plant's.

``problems`` would stop the controller on the real rig (an unstable loop, a discrete
controller at another sample time); in simulation it runs anyway, with them as warnings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import control as ct
import numpy as np

from elab.design.loop import close, credible, frd_margins, step
from elab.design.model import Model
from elab.design.observed import two_dof
from elab.design.plant_loop import closed_loop, loop_transfer
from elab.design.response import margins, step_response
from elab.laws import ControlLaw, LTIController, has_feedback
from elab.plants import Plant
from elab.validate import computable, finite_result


@dataclass(frozen=True)
class Report:
    plant: str
    kind: str
    poles: tuple[complex, ...]  # of the closed loop: in s, or in z for a discrete controller
    stable: bool
    gain_margin_db: float | None  # None: an open loop has no margins
    phase_margin_deg: float | None
    peak_u: float | None  # V, for a step of the default reference (None: unstable)
    u_max: float  # V, the actuator limit
    step_amplitude: float  # of the reference, in the reference output's unit
    problems: tuple[str, ...] = field(default=())  # stop it on the rig
    warnings: tuple[str, ...] = field(default=())
    domain: str = "s"  # "z": a discrete controller, checked on the ZOH model at its dt;
    # "trial": code, checked by trial runs on the model in its sandbox
    compute: dict[str, float | int] | None = None  # code: compute time per step in the trial
    trial: str | None = None  # code: what the trial ran

    @property
    def rig_ready(self) -> bool:
        return not self.problems

    def text(self) -> str:
        """The report as lines for a terminal."""
        rows = [f"controller: {self.kind} on {self.plant}"]
        if self.domain == "trial":
            rows.append(f"trial in the sandbox: {self.trial}")
            rows.append("closed loop: " + ("bounded" if self.stable else "FAILED or diverged"))
        else:
            rows.append("closed loop: " + ("stable" if self.stable else "UNSTABLE"))
            where = "poles" if self.domain == "s" else "poles (z, stable inside |z| < 1)"
            rows.append(f"  {where}: " + ", ".join(_pole(p) for p in self.poles))
        if self.gain_margin_db is not None and self.phase_margin_deg is not None:
            rows.append(
                f"  margins: gain {_db(self.gain_margin_db)}, phase {self.phase_margin_deg:.1f}°"
            )
        if self.peak_u is not None:
            rows.append(
                f"  peak |u| for a {self.step_amplitude:g} step of r: {self.peak_u:.3g} V"
                f" (limit ±{self.u_max:g} V)"
            )
        if self.compute and self.compute["steps"]:
            c = self.compute
            rows.append(
                f"  compute time per step: median {c['median_us']:.3g} µs, p99 "
                f"{c['p99_us']:.3g} µs, max {c['max_us']:.3g} µs; round trip median "
                f"{c['round_trip_median_us']:.3g} µs; {c['misses']} late of {c['steps']}"
                + (
                    f", {c['slow']} of them slower than the deadline in the controller itself"
                    if c.get("slow")
                    else LATE_NOT_SLOW
                    if c["misses"]
                    else ""
                )
            )
        for p in self.problems:
            rows.append("problem: " + p)
        for w in self.warnings:
            rows.append("warning: " + w)
        rows.append("ready for the rig" if self.rig_ready else "not for the rig (simulation only)")
        return "\n".join(rows)


#: late answers none of which the controller's own compute time made: not counted against
#: it (the app's words too: frontend/src/controllertext.ts)
LATE_NOT_SLOW = (
    ", none of them slow in the controller itself: the machine was busy (a simulation "
    "waits for them; on the rig each would hold the last u)"
)


def check(plant: Plant, law: ControlLaw) -> Report:
    """The report of ``law`` on ``plant``'s linear model; :class:`InvalidInput` for a law
    whose numbers overflow double precision in it (K = 1e308, a denominator of 1e-320)."""
    allowed = "a controller whose numbers keep its loop's arithmetic finite"
    with computable("controller", law, allowed), np.errstate(all="ignore"):
        report = _check(plant, law)
        finite_result("controller", law, allowed, report.poles)
    return report


def _check(plant: Plant, law: ControlLaw) -> Report:
    problems: list[str] = []
    warnings: list[str] = []
    match law:
        case LTIController(dt=dt) if dt is not None:  # stepped as it is, at its own dt
            if not math.isclose(dt, plant.Ts, rel_tol=1e-9):
                problems.append(
                    f"a discrete controller at dt = {dt:g} s; runs of {plant.id} step at "
                    f"Ts = {plant.Ts:g} s, so they must be started with Ts = {dt:g} s"
                )
            return _discrete(plant, law, problems, warnings)
    loop = closed_loop(plant, law)
    poles = tuple(complex(p) for p in np.linalg.eigvals(loop.A))
    stable = all(p.real < -1e-9 for p in poles)
    if not stable:
        worst = max(poles, key=lambda p: p.real)
        problems.append(
            f"the closed loop is unstable (pole {_pole(worst)} in the right half-plane)"
        )
    fastest = max((abs(p) for p in poles), default=0.0)
    if fastest * plant.Ts > 0.5:
        warnings.append(
            f"the fastest closed-loop pole (|s| = {fastest:.3g} rad/s) is too fast for the "
            f"sample time {plant.Ts:g} s (|s|·Ts = {fastest * plant.Ts:.2f} > 0.5): the "
            "sampled loop will not behave as the continuous one"
        )
    gm = pm = None
    if has_feedback(law):
        L = loop_transfer(plant, law)
        m = credible(margins(L), ct.ss(L))
        gm, pm = m.gain_margin_db, m.phase_margin_deg
        if stable and math.isfinite(pm) and pm < 30:
            warnings.append(f"a small phase margin ({pm:.1f}°): expect oscillation")
    amplitude = plant.signal.amplitude or 1.0
    peak = None
    if stable:
        slowest = min(-p.real for p in poles)
        T = min(max(plant.signal.duration, 5.0 / slowest), 600.0)
        u = step_response(loop, T, 4001, amplitude, u_output=-1).u
        peak = float(np.max(np.abs(u)))
        warnings += saturation(plant, amplitude, peak)
    return Report(
        plant=plant.id,
        kind=type(law).__name__,
        poles=tuple(sorted(poles, key=lambda p: (p.real, p.imag))),
        stable=stable,
        gain_margin_db=gm,
        phase_margin_deg=pm,
        peak_u=peak,
        u_max=plant.u_max,
        step_amplitude=amplitude,
        problems=tuple(problems),
        warnings=tuple(warnings),
    )


def _discrete(plant: Plant, law: LTIController, problems: list[str], warnings: list[str]) -> Report:
    """A discrete controller on the plant's exact (ZOH) discretisation at its ``dt``, as a
    run steps it: on the error r − y of the reference output."""
    assert law.dt is not None
    ref = plant.reference_output
    P = ct.c2d(ct.ss(plant.A, plant.B, plant.C[[ref]], plant.D[[ref]]), law.dt, "zoh")
    if law.num is not None and law.den is not None:
        C: Any = ct.ss(ct.tf(list(law.num), list(law.den), law.dt))
    else:
        C = ct.ss(np.array(law.A), np.array(law.B), np.array(law.C), np.array(law.D), law.dt)
    # in state space: the roots of the loop's polynomial near z = 1 are ill-conditioned
    poles = tuple(complex(z) for z in np.linalg.eigvals(ct.feedback(C * P, 1).A))
    stable = all(abs(z) < 1 - 1e-12 for z in poles)
    if not stable:
        worst = max(poles, key=abs)
        problems.append(f"the closed loop is unstable (pole {_pole(worst)} with |z| ≥ 1)")
    # on the frequency response: the polynomial method is ill-conditioned for z at 1 kHz
    # (scipy still warns while python-control converts the loop on the way)
    m = frd_margins(C * P)
    amplitude = plant.signal.amplitude or 1.0
    peak = None
    if stable:
        T = min(max(plant.signal.duration, 1.0), 600.0)
        u = step(close(Model(P.A, P.B, P.C, P.D, law.dt), two_dof(law)), law.dt, amplitude, T).u
        peak = float(np.max(np.abs(u)))
        warnings += saturation(plant, amplitude, peak)
    return Report(
        plant=plant.id,
        kind="LTIController",
        poles=tuple(sorted(poles, key=lambda p: (p.real, p.imag))),
        stable=stable,
        gain_margin_db=m.gain_margin_db,
        phase_margin_deg=m.phase_margin_deg,
        peak_u=peak,
        u_max=plant.u_max,
        step_amplitude=amplitude,
        problems=tuple(problems),
        warnings=tuple(warnings),
        domain="z",
    )


def saturation(plant: Plant, amplitude: float, peak: float) -> list[str]:
    """The warning of a step of ``amplitude`` asking for a ``peak`` |u| beyond the
    actuator: the same words for every report (linear, discrete, a code trial's)."""
    if peak <= plant.u_max:
        return []
    return [
        f"a step of {amplitude:g} asks for {peak:.3g} V against ±{plant.u_max:g} V: "
        "the input saturates, and the run will not follow the linear prediction"
    ]


def _pole(p: complex) -> str:
    if abs(p.imag) < 1e-9 * max(1.0, abs(p)):
        return f"{p.real:.4g}"
    return f"{p.real:.4g} {'+' if p.imag >= 0 else '−'} {abs(p.imag):.4g}j"


def _db(x: float) -> str:
    return "∞" if math.isinf(x) else f"{x:.1f} dB"
