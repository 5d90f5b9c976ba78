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
P_TEST = 0.01  # a residual test fails below this p-value


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
    be white and independent of past inputs if the model is right; each tested by its
    χ² statistic, and each correlation drawn with its 99 % band."""

    eps: Array
    lags: NDArray[np.int64]
    autocorrelation: Array  # r_ε(τ) / r_ε(0), τ = 0 … M
    cross_lags: NDArray[np.int64]
    cross_correlation: Array  # r_εu(τ) / √(r_ε(0) r_u(0)), τ = −M … M
    bound: float  # 99 %: 2.58 / √N
    input_autocorrelation: Array  # r_u(τ) / r_u(0), τ = 0 … M: the independence test's

    @property
    def p_white(self) -> float:
        """The p-value of ε being white (Box–Pierce: N Σ r_ε(τ)², τ = 1 … M, against
        χ²(M))."""
        auto = self.autocorrelation[1:]
        return _chi2_sf(self.eps.size * float(auto @ auto), auto.size)

    @property
    def p_independent(self) -> float:
        """The p-value of ε being independent of past inputs: N rᵀ R⁻¹ r against
        χ²(M + 1), r the normalised r_εu(τ), τ = 0 … M, and R the input's normalised
        autocorrelation matrix (Ljung 1999, eq. 16.66 with ε white: a coloured input
        correlates neighbouring lags, and the plain sum of squares fails a right model
        one time in eight). Negative lags, ε before u, speak of feedback, not of the
        model."""
        cross = self.cross_correlation[self.cross_lags >= 0]
        rho = self.input_autocorrelation
        R = rho[np.abs(np.subtract.outer(np.arange(rho.size), np.arange(rho.size)))]
        try:
            zeta = float(cross @ np.linalg.solve(R, cross))
        except np.linalg.LinAlgError:  # an input of fewer frequencies than lags
            zeta = float(cross @ np.linalg.lstsq(R, cross, rcond=1e-10)[0])
        return _chi2_sf(self.eps.size * zeta, cross.size)

    @property
    def white(self) -> bool:
        """White at the 1 % level. (Every lag inside its 99 % band, the plot's test, fails
        one good model in three over 25 lags.)"""
        return self.p_white >= P_TEST

    @property
    def independent(self) -> bool:
        """Independent of past inputs at the 1 % level."""
        return self.p_independent >= P_TEST


def _chi2_sf(x: float, dof: int) -> float:
    from scipy.special import chdtrc  # χ²'s survival function (scipy.stats: 0.4 s to import)

    return float(chdtrc(dof, x))


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
    ru = np.array([u[k:] @ u[: N - k] for k in range(max_lag + 1)])
    return Residuals(
        eps,
        np.arange(max_lag + 1),
        re / re[0],
        np.arange(-max_lag, max_lag + 1),
        cross / scale if scale > 0 else cross,
        2.58 / np.sqrt(N),
        ru / ru[0] if ru[0] > 0 else np.eye(1, max_lag + 1)[0],
    )
