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
from elab.ident.models import LinearModel

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


def compare(model: LinearModel, data: IdData, horizon: int | None = None,
            x0: Literal["zero", "estimate"] = "zero") -> Comparison:
    """Fit % of ``model`` on ``data``: simulation (``horizon`` None) or k-step prediction."""
    if data.ny != model.ny or data.nu != model.nu:
        raise InvalidInput("data", f"{data.ny} outputs, {data.nu} inputs",
                           f"{model.ny} outputs and {model.nu} inputs, as the model")
    if x0 not in ("zero", "estimate"):
        raise InvalidInput("x0", x0, "'zero' or 'estimate'")
    start = np.zeros(model.n)
    if x0 == "estimate" and model.n:
        start = _initial_state(model, data)
    yhat = (model.simulate(data.u, start) if horizon is None
            else model.predict(data, horizon, start))
    return Comparison(fit_percent(data.y, yhat), yhat, start)


def _initial_state(model: LinearModel, data: IdData) -> Array:
    """x₀ minimising ‖y − (ŷ from 0) − Ob x₀‖, Ob = [C; C A; C A²; …] (free response)."""
    free = data.y - model.simulate(data.u)
    Ob = np.empty((data.N, model.ny, model.n))
    M = model.C.copy()
    for t in range(data.N):
        Ob[t] = M
        M = M @ model.A
    x0, *_ = np.linalg.lstsq(Ob.reshape(-1, model.n), free.reshape(-1), rcond=None)
    return np.asarray(x0, dtype=np.float64)
