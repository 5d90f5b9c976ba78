"""Non-parametric estimates: correlation analysis (Ljung 1999, sec. 6.1), as MATLAB's
``cra``.

The input is prewhitened by its own AR model Aᵤ(q) u = w (order ``prewhiten_order``);
filtering the output by the same Aᵤ keeps the system's impulse response g:
y_f = G u_f + v_f with u_f = w white, so

    ĝ(k) = R̂_{y_f w}(k) / R̂_w(0),   k = 0 … M,

and, if the system had no response at lag k, ĝ(k) would scatter with standard deviation
σ = √(R̂_{y_f}(0) / (N R̂_w(0))). The band ±k·σ marks the lags whose estimate is noise;
the delay estimate is the first lag outside it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.signal
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData, require_exciting

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Correlation:
    lags: NDArray[np.int64]
    impulse: Array
    sigma: float
    k_sigma: float
    delay: int | None

    def as_dict(self) -> dict[str, Any]:
        band = self.k_sigma * self.sigma
        return {"lags": self.lags.tolist(), "impulse": self.impulse.tolist(),
                "band": [band] * len(self.lags), "delay": self.delay}


def cra(data: IdData, max_lag: int = 30, prewhiten_order: int = 10,
        k_sigma: float = 3.0) -> Correlation:
    """Impulse response estimate of a single-input single-output data set."""
    if data.ny != 1 or data.nu != 1:
        raise InvalidInput("data", f"{data.ny} outputs, {data.nu} inputs",
                           "one output and one input for correlation analysis")
    if not isinstance(max_lag, int) or max_lag < 1:
        raise InvalidInput("max_lag", max_lag, "an integer ≥ 1")
    if not isinstance(prewhiten_order, int) or prewhiten_order < 0:
        raise InvalidInput("prewhiten_order", prewhiten_order, "an integer ≥ 0")
    if not k_sigma > 0:
        raise InvalidInput("k_sigma", k_sigma, "a number > 0")
    N = data.N
    if 4 * (max_lag + prewhiten_order + 1) > N:
        need = 4 * (max_lag + prewhiten_order + 1)
        raise InvalidInput("data", f"{N} samples", f"at least {need} samples for {max_lag} "
                           f"lags and a prewhitening order of {prewhiten_order}")
    require_exciting(data.u, 1)
    u, y = data.u[:, 0], data.y[:, 0]
    a = _ar(u, prewhiten_order)
    w = scipy.signal.lfilter(a, [1.0], u)[prewhiten_order:]
    yf = scipy.signal.lfilter(a, [1.0], y)[prewhiten_order:]
    n = w.shape[0]
    rw0 = float(w @ w) / n
    g = np.array([float(yf[k:] @ w[:n - k]) / n for k in range(max_lag + 1)]) / rw0
    sigma = float(np.sqrt(float(yf @ yf) / n / (n * rw0)))
    outside = np.flatnonzero(np.abs(g) > k_sigma * sigma)
    return Correlation(np.arange(max_lag + 1), g, sigma, float(k_sigma),
                       int(outside[0]) if outside.size else None)


def _ar(u: Array, order: int) -> Array:
    """[1, a₁ … a_n]: the least-squares AR model of ``u`` (the prewhitening filter)."""
    if order == 0:
        return np.array([1.0])
    N = u.shape[0]
    Phi = np.column_stack([-u[order - i:N - i] for i in range(1, order + 1)])
    theta, *_ = np.linalg.lstsq(Phi, u[order:], rcond=None)
    return np.asarray(np.r_[1.0, theta], dtype=np.float64)
