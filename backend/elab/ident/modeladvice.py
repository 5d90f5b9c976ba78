"""Verdicts in plain words on an identified model (:mod:`elab.ident.advice` has the type
and the verdicts on the data): stability (and an integrator fitted on a record whose
means were removed), the validation fit (an absurd one explained), the residual tests,
an order at the top of its range, and, where the data's source knows the plant, the gap
to the plant's own model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from elab.ident.advice import Verdict, graded
from elab.ident.models import LinearModel
from elab.ident.validation import Residuals
from elab.plants import Plant

Array = NDArray[np.float64]
Poles = NDArray[np.complex128]

FIT_GOOD, FIT_POOR, FIT_ABSURD = 80.0, 50.0, -100.0
NEAR_ONE = 5e-3  # a pole this close to z = 1 integrates (200 samples or more)
P_POOR = 1e-4  # residuals this dependent on past inputs: the model misses dynamics
PHYSICS_GOOD = (3.0, 15.0)  # dB, degrees: a model this close to the physics agrees with it
PHYSICS_FAR = (6.0, 30.0)  # beyond either: it describes another plant


def on_model(
    poles: Poles,
    fit: float,
    fit_from: str,
    residuals: Residuals | None,
    detrend: str,
    order_top: bool,
    plant_unstable: float | None = None,
) -> tuple[Verdict, ...]:
    """A model with ``poles`` whose headline validation ``fit`` (%, the worst output;
    simulated ``fit_from`` a zero or an estimated state), residual analysis (``None``: not
    made), fitted to data detrended by ``detrend``; ``order_top``: its order was chosen at
    the top of its search range. ``plant_unstable``: the plant's own largest pole |z| at
    the data's sample time where its physics is unstable (a simulation of a right model
    then grows too, and its fit says nothing)."""
    if plant_unstable is not None:
        out = [_stability_of_unstable(poles, plant_unstable), _fit_unstable(fit, fit_from)]
    else:
        out = [_stability(poles), _fit(fit, fit_from)]
    out[1:1] = _integrator(poles, detrend)
    out += _residuals(residuals)
    if order_top:
        out.append(
            Verdict(
                "order",
                "caution",
                "the order was chosen at the top of its search range: the data may want more, "
                "or the extra states fit noise or the feedback path",
                "widen the range and compare the validation fits; check the feedback verdict",
            )
        )
    return tuple(out)


def _stability(poles: Poles) -> Verdict:
    top = float(np.max(np.abs(poles))) if poles.size else 0.0
    if 1.0 + 1e-9 < top <= 1.0 + NEAR_ONE:
        return Verdict(
            "stability",
            "caution",
            f"a pole at |z| = {top:.4g}, a hair outside the unit circle: an integrator (the "
            "plant's, if it integrates) estimated a little unstable; its simulation drifts "
            "slowly over long records",
            "if the plant integrates, this is its integrator; otherwise try a lower order",
        )
    if top > 1.0 + NEAR_ONE:
        return Verdict(
            "stability",
            "poor",
            f"unstable: a pole at |z| = {top:.4g}; its simulation grows without bound, and a "
            "controller designed on it is designed for another plant",
            "try a lower order, n4sid with the model kept stable, or check for feedback",
        )
    return Verdict("stability", "good", f"stable (the largest pole at |z| = {top:.4g})")


def _stability_of_unstable(poles: Poles, plant: float) -> Verdict:
    """An unstable plant's model: unstable like the plant is right; stable, or outside
    the unit circle by less than half the plant's margin (an integrator estimated a hair
    unstable, say), misses the plant's unstable mode."""
    top = float(np.max(np.abs(poles))) if poles.size else 0.0
    if top < 1.0 + (plant - 1.0) / 2:
        what = "stable" if top <= 1.0 else "hardly unstable"
        return Verdict(
            "stability",
            "poor",
            f"{what} (the largest pole at |z| = {top:.4g}), but the plant is unstable (its "
            f"physics has a pole at |z| = {plant:.4g} at this sample time): the model misses "
            "the mode a controller must catch",
            "try the plant's number of states, and data from a loop that moves every output",
        )
    return Verdict(
        "stability",
        "good",
        f"unstable like the plant (the largest pole at |z| = {top:.4g}; the physics' "
        f"{plant:.4g}): kept so, not reflected",
    )


def _fit_unstable(fit: float, start: str) -> Verdict:
    """The simulated fit of an unstable plant's model: no measure of it."""
    how = f"simulated from {'a zero' if start == 'zero' else 'the estimated'} initial state"
    shown = (
        f"{fit:.1f} %"
        if math.isfinite(fit) and fit >= FIT_ABSURD
        else ("below −100 %" if math.isfinite(fit) else "none (the simulation overflowed)")
    )
    return Verdict(
        "fit",
        "caution",
        f"validation fit {shown} ({how}): the plant is unstable, so a simulation of a right "
        "model grows with the unstable mode as the recording, held by its controller, does "
        "not; the fit does not judge this model",
        "judge it by its residuals and by the physics verdict",
    )


def _integrator(poles: Poles, detrend: str) -> list[Verdict]:
    if detrend in ("none", "operating_point") or not np.any(np.abs(poles - 1.0) < NEAR_ONE):
        return []
    return [
        Verdict(
            "integrator",
            "caution",
            f"a pole at z ≈ 1 (an integrator) on data whose {detrend}s were removed: "
            "removing the input's mean from an integrating plant adds a ramp the plant "
            "never made",
            "identify with detrend 'none' (record from rest)",
        )
    ]


def _fit(fit: float, start: str) -> Verdict:
    how = f"simulated from {'a zero' if start == 'zero' else 'the estimated'} initial state"
    if not math.isfinite(fit):
        return Verdict(
            "fit",
            "poor",
            f"no validation fit ({how}): the simulation overflowed, or the validation "
            "output is constant",
        )
    if fit < FIT_ABSURD:
        return Verdict(
            "fit",
            "poor",
            f"validation fit below −100 % ({how}): the model's output is more than twice as "
            "far from the data as their own mean is; it does not describe this plant",
            "check the delay, the order and the feedback verdict; a model that is unstable "
            "or has the wrong gain fits like this",
        )
    return graded(
        "fit",
        fit,
        FIT_GOOD,
        FIT_POOR,
        f"validation fit {fit:.1f} % ({how})",
        "try other orders or model kinds, and see the data verdicts",
    )


def _residuals(r: Residuals | None) -> list[Verdict]:
    if r is None:
        return []
    independent = r.p_independent
    if not r.independent:
        return [
            Verdict(
                "residuals",
                "poor" if independent < P_POOR else "caution",
                "the residuals correlate with past inputs (p = "
                f"{independent:.2g}): the model misses part of the dynamics from input to "
                "output",
                "raise the order or check the delay",
            )
        ]
    if not r.white:
        return [
            Verdict(
                "residuals",
                "caution",
                f"the residuals are not white (p = {r.p_white:.2g}): the noise is coloured and the "
                "model's noise description does not match it (its predictions are not the "
                "best possible)",
                "try armax or n4sid, which model the noise",
            )
        ]
    return [Verdict("residuals", "good", "white residuals, independent of past inputs")]


@dataclass(frozen=True)
class Physics:
    """The plant's own continuous model from the input to one output, ẋ = A x + B u,
    y = C x + D u, where the data's source knows it (a run of a lab plant); ``nominal``:
    the textbook's parameters of a real rig, which its own differ from by design."""

    A: Array
    B: Array
    C: Array
    D: Array
    nominal: bool = False
    #: s: the input was held this long per sample (the recording's Ts; 0: not held), a
    #: lag of half a sample that the model rightly has and the continuous physics not
    hold: float = 0.0


def unstable_pole(physics: Physics, Ts: float) -> float | None:
    """The physics' largest pole |z| at sample time ``Ts`` where the plant is unstable
    (a continuous pole right of the imaginary axis), else None."""
    right = float(np.max(np.linalg.eigvals(physics.A).real)) if physics.A.size else 0.0
    return math.exp(right * Ts) if right > 1e-9 else None


def physics_of(
    plant: Plant, outputs: tuple[str, ...], hold: float, nominal: bool
) -> Physics | None:
    """``plant``'s model from its input to the named ``outputs`` (``None`` where one is
    not the plant's), with the recording's ``hold`` (its sample time)."""
    names = [o.name for o in plant.outputs]
    if any(n not in names for n in outputs):
        return None
    rows = [names.index(n) for n in outputs]
    A, B, C, D = (np.asarray(m, dtype=np.float64) for m in (plant.A, plant.B, plant.C, plant.D))
    return Physics(A, B, C[rows], D[rows], nominal=nominal, hold=hold)


def physics_gap(
    model: LinearModel, physics: Physics, output: int = 0
) -> tuple[float, float, float, float]:
    """The largest |dB| and |°| between the model's and the physics' response from the
    input to ``output``, and the band (rad/s) they were compared over: from a tenth of the
    slowest nonzero pole to three times the fastest, below a fifth of the Nyquist
    frequency, outside ±15 % of any lightly damped zero (an antiresonance, where both dive
    and the gap means nothing)."""
    poles = np.linalg.eigvals(physics.A)
    moving = np.abs(poles[np.abs(poles) > 1e-9])
    nyquist = math.pi / model.Ts
    lo = max(float(moving.min()) / 10 if moving.size else 0.1, nyquist * 1e-4)
    hi = min(float(moving.max()) * 3 if moving.size else 10.0, nyquist / 5)
    w = np.logspace(math.log10(lo), math.log10(max(hi, lo * 1.01)), 200)
    zeros = _zeros(physics, output)
    for z in zeros[np.abs(zeros.real) < 0.2 * np.abs(zeros)]:
        w = w[np.abs(w / abs(z) - 1) > 0.15]
    if w.size == 0:
        return 0.0, 0.0, lo, hi
    true = _response(
        physics.A,
        physics.B,
        physics.C[output : output + 1],
        physics.D[output : output + 1],
        (1j * w).astype(np.complex128),
    )
    est = _response(
        model.A,
        model.B,
        model.C[output : output + 1],
        model.D[output : output + 1],
        np.exp(1j * w * model.Ts),
    )
    if physics.hold > 0:  # the zero-order hold: (1 − e^(−jωT)) / (jωT)
        jwt = 1j * w * physics.hold
        true = true * (1 - np.exp(-jwt)) / jwt
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = est / true
        db = np.abs(20 * np.log10(np.abs(ratio)))
        deg = np.abs(np.degrees(np.angle(ratio)))
    return float(np.nanmax(db)), float(np.nanmax(deg)), float(w[0]), float(w[-1])


def _zeros(physics: Physics, output: int) -> NDArray[np.complex128]:
    """The zeros from the input to ``output``: C adj(sI − A) B + D det(sI − A) =
    det(sI − A + B C) − det(sI − A) + D det(sI − A) for one input (B C of rank 1)."""
    A, B = physics.A, physics.B[:, :1]
    C, D = physics.C[output : output + 1], float(physics.D[output, 0])
    den = np.poly(A)
    num = np.poly(A - B @ C) - den + D * den
    big = np.abs(num).max() if num.size else 0.0
    keep = np.flatnonzero(np.abs(num) > 1e-9 * big) if big > 0 else np.array([], dtype=int)
    roots = np.roots(num[keep[0] :]) if keep.size > 1 else np.array([])
    return np.asarray(roots, dtype=np.complex128)


def _response(
    A: Array, B: Array, C: Array, D: Array, s: NDArray[np.complex128]
) -> NDArray[np.complex128]:
    """C (sI − A)⁻¹ B + D at each s, for the first input."""
    n = A.shape[0]
    M = s[:, None, None] * np.eye(n) - A[None, :, :]
    x = np.linalg.solve(M, np.broadcast_to(B[:, :1], (s.size, n, 1)).astype(complex))
    return np.asarray((C @ x)[:, 0, 0] + D[0, 0], dtype=np.complex128)


def on_physics(model: LinearModel, physics: Physics, name: str) -> Verdict:
    """How far ``model`` (its first output, ``name``) lies from the plant's own model."""
    db, deg, lo, hi = physics_gap(model, physics)
    found = (
        f"{name}: up to {db:.1f} dB and {deg:.0f}° from the plant's "
        f"{'nominal (textbook) ' if physics.nominal else ''}model over {lo:.3g}–{hi:.3g} "
        "rad/s (its antiresonances left out)"
    )
    if db <= PHYSICS_GOOD[0] and deg <= PHYSICS_GOOD[1]:
        return Verdict("physics", "good", found)
    if physics.nominal:  # a real rig is not its textbook: that is the lesson, not a fault
        return Verdict(
            "physics",
            "caution",
            found + ": a real rig differs from its textbook model, so a gap is expected; "
            "a large one is worth explaining",
            "compare with the link model's physical ratios (model kind link)",
        )
    far = db > PHYSICS_FAR[0] or deg > PHYSICS_FAR[1]
    return Verdict(
        "physics",
        "poor" if far else "caution",
        found,
        "see the data verdicts (feedback, noise, excitation); try an output-error model, "
        "every n-th sample, or the plant's proposals",
    )
