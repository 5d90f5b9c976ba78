"""ARX models by least squares, and the ARX order search (MATLAB's arx, struc, arxstruc,
selstruc) for single-output data; :func:`arx` also takes several inputs and outputs
(:mod:`elab.ident.multivariable`).

The model (Ljung 1999, sec. 4.2):

    A(q) y(t) = B(q) u(t − nk) + e(t),
    A(q) = 1 + a₁ q⁻¹ + … + a_na q⁻ⁿᵃ,   B(q) = b₁ + b₂ q⁻¹ + … + b_nb q⁻ⁿᵇ⁺¹,

is linear in θ = [a₁ … a_na, b₁ … b_nb]: y(t) = φ(t)ᵀ θ + e(t) with
φ(t) = [−y(t−1) … −y(t−na), u(t−nk) … u(t−nk−nb+1)], so θ̂ minimises Σ ε(t)² over the
samples whose regressors lie inside the data (no assumed initial values), as MATLAB does.
As in MATLAB, B is reported with nk leading zeros: B = [0 … 0 b₁ … b_nb].
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable
from dataclasses import replace
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData, require_exciting
from elab.ident.models import LinearModel
from elab.ident.multivariable import Orders, arx_per_output, miso_regressors
from elab.ident.parameters import ArxParameters

Array = NDArray[np.float64]


def _one_output(data: IdData, what: str) -> tuple[Array, Array]:
    if data.ny != 1:
        raise InvalidInput(
            "data", f"{data.ny} outputs", f"one output for {what} (search each on its own)"
        )
    return data.y[:, 0], data.u


def _check_orders(na: int, nb: int, nk: int) -> None:
    for name, value, low in (("na", na, 0), ("nb", nb, 1), ("nk", nk, 0)):
        if not isinstance(value, int | np.integer) or isinstance(value, bool) or value < low:
            raise InvalidInput(name, value, f"an integer ≥ {low}")


def regressors(y: Array, u: Array, na: int, nb: int, nk: int, start: int) -> tuple[Array, Array]:
    """Φ (rows φ(t)ᵀ for t = start … N−1) and Y = y(start …)."""
    return miso_regressors(y, u[:, None], na, [nb], [nk], start)


def arx(data: IdData, na: Orders, nb: Orders, nk: Orders = 1) -> LinearModel:
    """The least-squares ARX model of orders ``na``, ``nb`` and delay ``nk``.

    Several inputs or outputs: one least-squares problem per output, as GNU Octave's
    ``arx`` (:func:`elab.ident.multivariable.arx_per_output`); ``na`` an integer or one per
    output, ``nb`` and ``nk`` an integer or an ny × nu matrix.
    """
    if data.ny == 1 and data.nu == 1:
        return _arx_siso(data, _scalar(na), _scalar(nb), _scalar(nk))
    return arx_per_output(data, na, nb, nk)


def _scalar(order: Orders) -> Any:
    """A one-element list or array as its element: one output's orders as 1 × 1 matrices."""
    try:
        a = np.asarray(order)
    except ValueError:  # a ragged list: _check_orders names it
        return order
    return a.item() if a.ndim and a.size == 1 else order


def _arx_siso(data: IdData, na: int, nb: int, nk: int) -> LinearModel:
    _check_orders(na, nb, nk)
    y, u = data.y[:, 0], data.u[:, 0]
    start = max(na, nb + nk - 1)
    d = na + nb
    if data.N - start <= d:
        raise InvalidInput(
            "data",
            f"{data.N} samples",
            f"more than {start + d} samples for [na nb nk] = [{na} {nb} {nk}] ({d} parameters)",
        )
    require_exciting(data.u, nb)
    Phi, Y = regressors(y, u, na, nb, nk, start)
    theta, *_ = np.linalg.lstsq(Phi, Y, rcond=None)
    eps = Y - Phi @ theta
    n = Y.shape[0]
    loss = float(eps @ eps / n)
    lam = float(eps @ eps / max(n - d, 1))
    try:
        cov = lam * np.linalg.inv(Phi.T @ Phi)
        sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        sd = np.full(d, np.nan)
    a = np.r_[1.0, theta[:na]]
    b = np.r_[np.zeros(nk), theta[na:]]
    model = from_polynomials(a, b, np.array([1.0]), data.Ts, lam)
    return replace(
        model,
        parameters=ArxParameters(
            na=na,
            nb=nb,
            nk=nk,
            A=a,
            B=b,
            dA=np.r_[0.0, sd[:na]],
            dB=np.r_[np.zeros(nk), sd[na:]],
            loss=loss,
            fpe=loss * (1 + d / n) / (1 - d / n),
            aic=math.log(loss) + 2 * d / n if loss > 0 else -math.inf,  # an exact fit
            samples=n,
        ),
    )


def from_polynomials(a: Array, b: Array, c: Array, Ts: float, lam: float) -> LinearModel:
    """A(q) y = B(q) u + C(q) e (a₀ = c₀ = 1, b₀ may be 0) as an innovations state space
    in observer form: with n = max(deg A, deg B, deg C),
    x(t+1) = F x(t) + G u(t) + K e(t), y(t) = H x(t) + D u(t) + e(t)."""
    n = max(len(a), len(b), len(c)) - 1
    a, b, c = (np.r_[p, np.zeros(n + 1 - len(p))] for p in (a, b, c))
    d0 = b[0]
    F = np.zeros((n, n))
    if n:
        F[:, 0] = -a[1:]
        F[:-1, 1:] = np.eye(n - 1)
    G = (b[1:] - a[1:] * d0)[:, None]
    K = (c[1:] - a[1:])[:, None]
    H = np.zeros((1, n))
    if n:
        H[0, 0] = 1.0
    return LinearModel(F, G, H, np.array([[d0]]), K, Ts, np.array([[lam]]))


def struc(na: Iterable[int], nb: Iterable[int], nk: Iterable[int]) -> NDArray[np.int64]:
    """Every [na nb nk] combination, one per row (MATLAB's struc)."""
    rows = list(itertools.product(na, nb, nk))
    if not rows:
        raise InvalidInput("struc", rows, "at least one structure")
    out = np.array(rows, dtype=np.int64)
    for j, (name, low) in enumerate((("na", 0), ("nb", 1), ("nk", 0))):
        bad = out[:, j] < low
        if bad.any():
            raise InvalidInput(name, int(out[bad, j][0]), f"orders ≥ {low}")
    return out


def arxstruc(ze: IdData, zv: IdData, structures: Array) -> Array:
    """Validation loss of the ARX model of each structure: rows [na, nb, nk, V].

    As MATLAB's arxstruc: each model is estimated on ``ze`` exactly as :func:`arx` does,
    and V is the mean squared one-step prediction error over every sample of ``zv``, with
    values before the first sample taken as zero. One padded regressor matrix per delay
    serves every (na, nb): a model solves a sub-block of its normal equations. Several
    inputs (one output): a row's nb and nk apply to every input.
    """
    S = np.asarray(structures, dtype=np.int64)
    if S.ndim != 2 or S.shape[1] != 3 or S.shape[0] == 0:
        raise InvalidInput("structures", f"shape {S.shape}", "rows [na nb nk]")
    ye, ue = _one_output(ze, "arxstruc")
    yv, uv = _one_output(zv, "arxstruc")
    nu = ue.shape[1]
    if uv.shape[1] != nu:
        raise InvalidInput("zv", f"{uv.shape[1]} inputs", f"{nu} inputs, as ze")
    na_max, nb_max = int(S[:, 0].max()), int(S[:, 1].max())
    head = max(na_max, int((S[:, 1] + S[:, 2]).max()) - 1)  # rows where a lag is missing
    if ze.N - head <= na_max + nu * nb_max:
        raise InvalidInput(
            "ze",
            f"{ze.N} samples",
            f"more than {head + na_max + nu * nb_max} samples for these structures",
        )
    require_exciting(ze.u, nb_max)
    out = np.empty((S.shape[0], 4))
    for nk in np.unique(S[:, 2]):
        nk = int(nk)
        Pe, Ye = _padded(ye, ue, na_max, nb_max, nk)
        Pv, Yv = _padded(yv, uv, na_max, nb_max, nk)
        tail = slice(head, None)
        R, r = Pe[tail].T @ Pe[tail], Pe[tail].T @ Ye[tail]
        Rv, rv, yy = Pv.T @ Pv, Pv.T @ Yv, float(Yv @ Yv)
        for i in np.flatnonzero(S[:, 2] == nk):
            na, nb = int(S[i, 0]), int(S[i, 1])
            idx = np.concatenate(
                [np.arange(na), *(na_max + j * nb_max + np.arange(nb) for j in range(nu))]
            )
            own = max(na, nb + nk - 1)  # arx's first row for this model
            H = Pe[own:head][:, idx]
            theta = np.linalg.solve(R[np.ix_(idx, idx)] + H.T @ H, r[idx] + H.T @ Ye[own:head])
            V = (yy - 2 * theta @ rv[idx] + theta @ Rv[np.ix_(idx, idx)] @ theta) / Yv.shape[0]
            out[i] = (na, nb, nk, V)
    return out


def _padded(y: Array, U: Array, na: int, nb: int, nk: int) -> tuple[Array, Array]:
    """Regressors for every sample, values before the data taken as zero; every input
    with ``nb`` lags from delay ``nk``."""
    pad, nu = na + nb + nk, U.shape[1]
    y, U = np.r_[np.zeros(pad), y], np.vstack([np.zeros((pad, nu)), U])
    return miso_regressors(y, U, na, [nb] * nu, [nk] * nu, pad)


def selstruc(
    V: Array, criterion: Literal[0, "aic", "mdl"] | float = 0, N: int | None = None
) -> tuple[int, int, int]:
    """The structure with the least (penalised) loss. ``0``: the loss itself; ``"aic"``:
    V (1 + 2d/N); ``"mdl"``: V (1 + log(N) d/N); a number α: V (1 + α d/N); d = na + nb.
    ``N`` (default: 1000, as the losses carry no sample count) weighs the penalty."""
    V = np.asarray(V, dtype=float)
    if V.ndim != 2 or V.shape[1] != 4 or V.shape[0] == 0:
        raise InvalidInput("V", f"shape {V.shape}", "rows [na nb nk loss] from arxstruc")
    n = 1000 if N is None else N
    d = V[:, 0] + V[:, 1]
    if isinstance(criterion, str):
        if criterion not in ("aic", "mdl"):
            raise InvalidInput("criterion", criterion, "0, 'aic', 'mdl' or a number")
        alpha = 2.0 if criterion == "aic" else math.log(n)
    else:
        alpha = float(criterion)
    i = int(np.argmin(V[:, 3] * (1 + alpha * d / n)))
    return int(V[i, 0]), int(V[i, 1]), int(V[i, 2])
