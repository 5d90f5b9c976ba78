"""Model validation: how well a model reproduces data it was not fitted to (Ljung 1999,
ch. 16), as MATLAB's ``compare``.

fit = 100 · (1 − ‖y − ŷ‖ / ‖y − mean(y)‖) per output, where ŷ is the model's simulated
output (``horizon=None``) or its ``horizon``-step-ahead prediction, from a zero initial
state or from the initial state that fits the data best (least squares on
y − ŷ₀ = C Aᵗ x₀, which is linear in x₀).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData
from elab.ident.models import LinearModel, fit_state, initial_state, observability

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Comparison:
    fit: Array  # % per output
    yhat: Array  # (N, ny)
    x0: Array


def fit_percent(y: Array, yhat: Array) -> Array:
    """100 · (1 − ‖y − ŷ‖ / ‖y − mean(y)‖) for each column."""
    spread = np.linalg.norm(y - y.mean(axis=0), axis=0)
    err = np.linalg.norm(y - yhat, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(spread > 0, 100 * (1 - err / spread), -np.inf)


def compare(
    model: LinearModel,
    data: IdData,
    horizon: int | None = None,
    x0: Literal["zero", "estimate"] = "zero",
) -> Comparison:
    """Fit % of ``model`` on ``data``: simulation (``horizon`` None) or k-step prediction."""
    if data.ny != model.ny or data.nu != model.nu:
        raise InvalidInput(
            "data",
            f"{data.ny} outputs, {data.nu} inputs",
            f"{model.ny} outputs and {model.nu} inputs, as the model",
        )
    if x0 not in ("zero", "estimate"):
        raise InvalidInput("x0", x0, "'zero' or 'estimate'")
    start = np.zeros(model.nx)
    if x0 == "estimate" and model.nx:
        start = _initial_state(model, data, horizon)
    yhat = model.simulate(data.u, start) if horizon is None else model.predict(data, horizon, start)
    return Comparison(fit_percent(data.y, yhat), yhat, start)


def _initial_state(model: LinearModel, data: IdData, horizon: int | None) -> Array:
    """x₀ that fits the free response best (:func:`initial_state`): of the simulation,
    C Aᵗ x₀; of the k-step predictor, whose state runs through A − K C (a predictor with
    slow noise dynamics — an ARMAX C with roots near the unit circle — forgets a wrong
    start only slowly: from the simulation's x₀ its one-step fit was −315 %, from its own
    x₀ the fit the data allow)."""
    if horizon is None:
        return initial_state(model.A, model.C, data.y - model.simulate(data.u))
    free = data.y - model.predict(data, horizon)
    F = model.A - model.K @ model.C
    h, N = horizon, data.N
    first = observability(F, model.C, min(h - 1, N)) if h > 1 else np.empty((0, model.ny, model.nx))
    rest = observability(F, model.C @ np.linalg.matrix_power(model.A, h - 1), max(N - h + 1, 0))
    return fit_state(np.concatenate([first, rest])[:N], free)


@dataclass(frozen=True)
class Residuals:
    """Residual analysis (Ljung 1999, sec. 16.6): the one-step prediction errors ε should
    be white and independent of past inputs if the model is right."""

    eps: Array
    lags: NDArray[np.int64]
    autocorrelation: Array  # r_ε(τ) / r_ε(0), τ = 0 … M
    cross_lags: NDArray[np.int64]
    cross_correlation: Array  # r_εu(τ) / √(r_ε(0) r_u(0)), τ = −M … M
    bound: float  # 99 %: 2.58 / √N

    @property
    def white(self) -> bool:
        return bool(np.all(np.abs(self.autocorrelation[1:]) <= self.bound))

    @property
    def independent(self) -> bool:
        return bool(np.all(np.abs(self.cross_correlation) <= self.bound))


def resid(model: LinearModel, data: IdData, max_lag: int = 25) -> Residuals:
    """Correlations of the residuals of a single-output, single-input model on ``data``."""
    if data.ny != 1 or data.nu != 1 or model.ny != 1 or model.nu != 1:
        raise InvalidInput(
            "data",
            f"{data.ny} outputs, {data.nu} inputs",
            "one output and one input for residual analysis",
        )
    if not isinstance(max_lag, int) or not 1 <= max_lag < data.N // 4:
        raise InvalidInput("max_lag", max_lag, f"an integer in 1 … {data.N // 4 - 1}")
    eps = (data.y - model.predict(data, 1))[:, 0]
    u = data.u[:, 0] - data.u[:, 0].mean()
    N = eps.shape[0]
    re = np.array([eps[k:] @ eps[: N - k] for k in range(max_lag + 1)]) / N
    cross = (
        np.array(
            [
                (eps[k:] @ u[: N - k]) if k >= 0 else (eps[: N + k] @ u[-k:])
                for k in range(-max_lag, max_lag + 1)
            ]
        )
        / N
    )
    scale = np.sqrt(re[0] * (u @ u) / N)
    return Residuals(
        eps,
        np.arange(max_lag + 1),
        re / re[0],
        np.arange(-max_lag, max_lag + 1),
        cross / scale if scale > 0 else cross,
        2.58 / np.sqrt(N),
    )
