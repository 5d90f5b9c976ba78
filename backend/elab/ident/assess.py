"""What an estimated model is worth: its fits on the validation and estimation data
(Ljung 1999, ch. 16; MATLAB's ``compare``), which validation fit to head with, its
residual analysis, its continuous-time form, and the notes a reader of it must see.
"""

from __future__ import annotations

import math
from typing import assert_never

import numpy as np

from elab.ident.data import IdData
from elab.ident.models import LinearModel, d2c
from elab.ident.parameters import (
    ArmaxParameters,
    ArxParameters,
    LinkParameters,
    MimoArxParameters,
    N4sidParameters,
    OeParameters,
)
from elab.ident.pem import C_RADIUS
from elab.ident.results import Fits, Headline, ModelResult
from elab.ident.validation import compare, resid

#: time constants a mode must decay within the validation record for the fit from zero
#: to lead (5: to 1 %; with 1, an integrator estimated at |z| = 0.9993 on 1,500 samples
#: "fitted" 3.8 % from zero, 95 % from its state)
DECAYS = 5.0
RESIDUAL_LAGS = 25  # at most; and fewer than a quarter of the validation samples


def assess(name: str, m: LinearModel, ze: IdData, zv: IdData) -> ModelResult:
    """``m`` compared with the validation part ``zv`` (simulated from a zero and from the
    best initial state, and one step ahead) and with the estimation part ``ze``
    (simulated from the best initial state); its residuals on ``zv`` (one input and one
    output) and its continuous-time form."""
    fits = Fits(
        validation_simulation=compare(m, zv),  # zero initial state, as the published figures
        validation_simulation_x0=compare(m, zv, x0="estimate"),
        validation_one_step=compare(m, zv, horizon=1, x0="estimate"),
        estimation_simulation=compare(m, ze, x0="estimate"),
        headline=headline(m, zv.N),
    )
    residuals = None
    lag = min(RESIDUAL_LAGS, zv.N // 4 - 1)
    if ze.ny == 1 and ze.nu == 1 and lag >= 1:
        residuals = resid(m, zv, max_lag=lag)
    return ModelResult(name, m, fits, residuals, d2c(m))


def headline(m: LinearModel, N: int) -> Headline:
    """Which validation fit means something for this model: from a zero initial state
    (the published figures' convention) when every mode decays to 1 % within the
    ``N``-sample validation record (its time constant at most a fifth of it), else from
    the estimated initial state — an integrating or unstable
    plant (or one slower than the record) starts where the record starts, and a
    zero-state simulation mostly measures that start (an ARX model of an integrating
    plant whose poles matched the physics to four digits "fitted" −36.82 % from a zero
    state)."""
    slowest = float(np.max(np.abs(m.poles))) if m.nx else 0.0
    if slowest < math.exp(-DECAYS / max(N, 1)):
        return Headline("zero", "every mode decays within the validation record")
    if slowest > 1.0:
        why = f"a pole at |z| = {slowest:.4g} is unstable"
    else:
        why = (
            f"a pole at |z| = {slowest:.4g} takes more than a fifth of the {N}-sample record "
            "to decay"
        )
    return Headline("estimated", f"{why}, so the initial state is estimated")


def model_notes(name: str, m: LinearModel) -> list[str]:
    """What a reader of model ``name`` must know: an unstable estimate kept or reflected
    (with the estimation fits that chose), C's roots held at the margin, a Kalman gain
    that could not be had."""
    p = m.parameters
    match p:
        case N4sidParameters():
            chose = ""
            if p.choice is not None:
                chose = (
                    f": estimation fit {_pct(p.choice.fit_as_estimated)} as estimated, "
                    f"{_pct(p.choice.fit_reflected)} reflected"
                )
            if p.reflected:
                moved = ", ".join(f"|z| {a:.4g} → {b:.4g}" for a, b in p.reflected)
                notes = [
                    f"{name}: poles outside the unit circle were reflected into it ({moved}){chose}"
                ]
            else:
                notes = _unstable(name, m, chose)
            if p.kalman == "none":
                notes.append(
                    f"{name}: no Kalman gain (the Riccati equation had no stabilising "
                    "solution): K = 0, so its one-step prediction is its simulation"
                )
            return notes
        case ArmaxParameters():
            notes = _unstable(name, m)
            if p.c_at_margin:
                notes.append(
                    f"{name}: C's roots were held at |z| = {C_RADIUS:g}: the noise model wants "
                    "one on the unit circle (a drift, or a disturbance that integrates); the "
                    "one-step predictor stays stable, but try detrending the data or a model "
                    "with an integrator"
                )
            return notes
        case ArxParameters() | MimoArxParameters() | OeParameters() | None:
            return _unstable(name, m)
        case LinkParameters():
            return []  # its integrator is the servo's, on the unit circle by construction
        case _:
            assert_never(p)


def _unstable(name: str, m: LinearModel, chose: str = "") -> list[str]:
    """A pole outside the unit circle, kept (``chose``: the fits that kept it)."""
    top = float(np.max(np.abs(m.poles))) if m.nx else 0.0
    if top > 1.0:
        return [
            f"{name}: a pole outside the unit circle (|z| = {top:.4g}): the model is "
            f"unstable as estimated, and kept so{chose}"
        ]
    return []


def _pct(v: float) -> str:
    return f"{v:.2f} %" if math.isfinite(v) else "−∞ %"
