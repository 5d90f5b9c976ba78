"""Subspace identification of state-space models (MATLAB's ``n4sid``), by PO-MOESP
(Verhaegen 1994; Van Overschee & De Moor 1996, ch. 4; Ljung 1999, sec. 10.6).

With ``s`` block rows ("horizon"), j = N − 2s + 1 columns and the block Hankel matrices
of past and future inputs and outputs (rows u(t)ᵀ … u(t+s−1)ᵀ),

    [U_f; W_p; Y_f] = L Q,   W_p = [U_p; Y_p],   L lower block triangular
(L is the Cholesky factor of the correlation matrix H Hᵀ, as SLICOT computes it by
default, or comes from a QR step when that is ill-conditioned),

the block L₃₂ (future outputs against past data, with the future inputs projected out)
is Γ_s X̂: its left singular vectors give the extended observability matrix
Γ_s = [C; C A; …; C A^{s−1}] = U₁ Σ₁^{1/2}, and its singular values choose the order
(these are the singular values SLICOT's IB01AD — and so GNU Octave's ``n4sid`` — report).
A and C follow from the shift structure, Γ_s(first s−1 blocks) A = Γ_s(last s−1 blocks);
A is kept as estimated, stable or not (a lightly damped plant's estimate may have a pole
just outside the unit circle; the zero-padded estimate of Chui & Maciejowski 1996, once
the default, pulled every pole inward and fitted 13 % where the estimate fitted 96.7 %).
``stable=True`` reflects only the poles outside the unit circle into it (λ → 1/λ̄), which
keeps the others; ``parameters.reflected`` lists what moved. B and D come from the R
factor as SLICOT computes them for N4SID, or by the least squares of the simulated
output (:mod:`elab.ident.input_matrices`); x₀ by least squares on the free response.
The states X̂ = Γ_s⁺ L₃₂ L₂₂⁺ W_p give the residual covariances of the state equations,
and the Kalman gain K solves the filter Riccati equation for them.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData, require_exciting
from elab.ident.input_matrices import simulate, simulation_bd, subspace_bd
from elab.ident.models import LinearModel, initial_state, observability
from elab.ident.parameters import N4sidParameters, UnstableChoice

Array = NDArray[np.float64]
MAX_HORIZON = 100
BD_METHODS = ("subspace", "simulation")
BD = Literal["subspace", "simulation"]
Stable = bool | Literal["auto"]
GAP = 100.0  # a fall of the singular values this large decides the order


@dataclass(frozen=True)
class Subspace:
    """The shared part of a subspace identification: everything but the order."""

    data: IdData
    horizon: int
    singular_values: Array
    U1: Array  # left singular vectors of L₃₂ (s·ny × s·ny)
    L: Array  # [U_f; U_p; Y_p; Y_f] = L Q, lower triangular
    states_map: Array  # U₁ᵀ L₃₂ L₂₂⁺: times W_p, row i over √σᵢ is state i at s … s+j−1

    @property
    def max_order(self) -> int:
        """The largest order the horizon supports (n < s, as SLICOT requires)."""
        return min(
            self.horizon - 1, int(np.sum(self.singular_values > 1e-12 * self.singular_values[0]))
        )


def _exciting_horizon(data: IdData, s: int) -> int | None:
    """The largest horizon below ``s`` the input is exciting enough for (bisection on the
    persistence of excitation, which holds for every order below one that holds)."""
    lo, hi = 1, s  # order 2·lo holds (or lo = 1: none known), 2·hi does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        try:
            require_exciting(data.u, 2 * mid)
            lo = mid
        except InvalidInput:
            hi = mid
    return lo if lo >= 2 else None


def decompose(data: IdData, horizon: int | None = None) -> Subspace:
    """The LQ factorisation and the SVD every order shares (``horizon`` s: default
    SLICOT's, s = min(⌊(N+1) / (2 (nu+ny+1))⌋, 16) … at least 2)."""
    N, nu, ny = data.N, data.nu, data.ny
    s_cap = (N + 1) // (2 * (nu + ny + 1))
    s = min(s_cap, 16) if horizon is None else horizon
    if not isinstance(s, int) or isinstance(s, bool) or not 2 <= s <= min(s_cap, MAX_HORIZON):
        raise InvalidInput(
            "horizon",
            horizon,
            f"an integer in 2 … {min(s_cap, MAX_HORIZON)} for {N} samples ((N+1) / (2 (nu+ny+1)))",
        )
    w = np.hstack([data.u, data.y])
    R = _correlation(w, s)
    if not _excites(R, nu):  # not clearly: the input's own check decides, and says why
        try:
            require_exciting(data.u, 2 * s)
        except InvalidInput:
            top = _exciting_horizon(data, s)
            if top is None:
                raise  # not even horizon 2: the input's own error says why
            if horizon is not None:
                raise InvalidInput(
                    "horizon",
                    horizon,
                    f"an integer in 2 … {top} for this input: it is persistently exciting of "
                    f"order {2 * top} but not {2 * s} (a horizon s needs order 2s)",
                ) from None
            s = top  # the default: the largest horizon the input supports
            R = _correlation(w, s)
    L, cholesky = _lq_factor(data, s, R)
    a, b = s * nu, s * (nu + ny) + s * nu
    L22, L32 = L[a:b, a:b], L[b:, a:b]
    U1, sv, _ = np.linalg.svd(L32)
    seen = U1.T @ L32
    if cholesky:  # L₂₂ triangular and well-conditioned: its inverse is its pseudo-inverse
        import scipy.linalg  # here: the web process imports this module, not scipy

        states_map = scipy.linalg.solve_triangular(L22, seen.T, trans="T", lower=True).T
    else:
        states_map = seen @ np.linalg.pinv(L22)
    return Subspace(data, s, sv, U1, L, states_map)


#: an input whose lag matrix's eigenvalues span less than this is exciting without doubt;
#: closer to :func:`~elab.ident.data.require_exciting`'s 1e-13, that check decides
CLEARLY_EXCITING = 1e-11


def _excites(R: Array, nu: int) -> bool:
    """Whether each input is clearly persistently exciting of order 2s, judged on the
    correlation matrix already at hand (its blocks of an input's lags are the ΦᵀΦ that
    :func:`~elab.ident.data.require_exciting` forms, over the same samples)."""
    for c in range(nu):
        lam = np.linalg.eigvalsh(R[:, :, c, c])
        if not lam[-1] > 0 or not lam[0] > CLEARLY_EXCITING * lam[-1]:
            return False
    return True


@functools.lru_cache(maxsize=16)
def _rows(s: int, nu: int, ny: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The lag and the channel (of w = [u, y]) of each row of [U_f; U_p; Y_p; Y_f]."""
    lag, channel = [], []
    for first, chans in ((s, range(nu)), (0, range(nu)), (0, range(nu, nu + ny))):
        lag += [first + i for i in range(s) for _ in chans]
        channel += [c for _ in range(s) for c in chans]
    lag += [s + i for i in range(s) for _ in range(ny)]
    channel += [c for _ in range(s) for c in range(nu, nu + ny)]
    return _readonly(np.array(lag)), _readonly(np.array(channel))


def _correlation(w: Array, s: int) -> Array:
    """R[ℓ, m] = Σ_{t<j} w(t+ℓ) w(t+m)ᵀ for ℓ, m < 2s (j = N − 2s + 1), by the Hankel
    structure (as SLICOT's IB01MD): R[ℓ+1, m+1] = R[ℓ, m] + w(ℓ+j) w(m+j)ᵀ − w(ℓ) w(m)ᵀ,
    so only R[ℓ, 0] needs a pass over the data. The recurrence runs down every diagonal
    at once, as one cumulative sum (numpy's adds in order: the same numbers as a loop)."""
    N, p = w.shape
    k = 2 * s
    j = N - k + 1
    lags = np.lib.stride_tricks.sliding_window_view(w, (j, p))[:, 0]  # (k, j, p)
    end, start = w[j:].reshape(-1), w[: k - 1].reshape(-1)  # w(ℓ + j) and w(ℓ), ℓ < 2s − 1
    # step[ℓ, m, p, q] = w(ℓ+j)_p w(m+j)_q − w(ℓ)_p w(m)_q
    step = (np.outer(end, end) - np.outer(start, start)).reshape(k - 1, p, k - 1, p)
    d, m, ds, i = _diagonals(k)
    X = np.zeros((k, k, p, p))  # X[d, 0] = R[d, 0]; X[d, i + 1] = step[d + i, i]
    X[:, 0] = np.matmul(lags.transpose(0, 2, 1), w[:j])  # (einsum's path search: 0.1 ms)
    X[ds, i + 1] = step[ds + i, :, i]
    along = np.cumsum(X, axis=1)  # along[d, m] = R[d + m, m]
    R = np.empty((k, k, p, p))
    R[d + m, m] = along[d, m]
    upper = np.triu_indices(k, 1)
    R[upper] = R[upper[1], upper[0]].transpose(0, 2, 1)
    return R


@functools.lru_cache(maxsize=16)
def _diagonals(k: int) -> tuple[NDArray[np.intp], ...]:
    """For :func:`_correlation`: the (d, m) with d + m < k (R[d + m, m]) and the (d, i)
    with d + i < k − 1 (the steps down diagonal d)."""
    total = np.add.outer(np.arange(k), np.arange(k))
    return tuple(_readonly(a) for a in (*np.nonzero(total <= k - 1), *np.nonzero(total <= k - 2)))


def _readonly(a: NDArray[np.intp]) -> NDArray[np.intp]:
    """A cached index array, safe to share."""
    a.flags.writeable = False
    return a


def _hankel(data: IdData, s: int) -> Array:
    """[U_f; U_p; Y_p; Y_f]: s block rows each, j = N − 2s + 1 columns."""
    j = data.N - 2 * s + 1

    def block(x: Array, start: int) -> Array:
        return np.vstack([x[start + i : start + i + j].T for i in range(s)])

    return np.vstack([block(data.u, s), block(data.u, 0), block(data.y, 0), block(data.y, s)])


def _past(data: IdData, s: int) -> Array:
    """W_p = [U_p; Y_p] (s block rows each, j columns), as :func:`_hankel` orders them,
    made from windows of the record (not the whole Hankel matrix and its slices)."""
    j = data.N - 2 * s + 1

    def block(x: Array) -> Array:  # rows lag-major: x(i + t), channel c at row i·p + c
        windows = np.lib.stride_tricks.sliding_window_view(x, j, axis=0)[:s]  # (s, p, j)
        return windows.reshape(s * x.shape[1], j)

    return np.vstack([block(data.u), block(data.y)])


def _lq_factor(data: IdData, s: int, R: Array) -> tuple[Array, bool]:
    """L of H = L Q, H = [U_f; U_p; Y_p; Y_f]: the Cholesky factor of H Hᵀ (SLICOT's
    default, the "Cholesky algorithm applied to the correlation matrix", H Hᵀ from the
    Hankel structure: ``R``, :func:`_correlation`), or of a QR step when H Hᵀ is too
    ill-conditioned for it; and whether it is the well-conditioned Cholesky factor."""
    import scipy.linalg  # here: the web process imports this module, not scipy

    lag, ch = _rows(s, data.nu, data.ny)
    try:
        HHt = R[lag[:, None], lag[None, :], ch[:, None], ch[None, :]]
        L = scipy.linalg.cholesky(HHt, lower=True, check_finite=False)
        d = np.abs(np.diag(L))
        if d.min() > 1e-6 * d.max():
            return np.asarray(L, dtype=np.float64), True
    except np.linalg.LinAlgError:
        pass
    H = _hankel(data, s)
    Rq = scipy.linalg.qr(H.T, mode="r", check_finite=False)[0]
    return np.asarray(Rq[: H.shape[0]].T, dtype=np.float64), False


def n4sid(
    data: IdData,
    order: int | None = None,
    horizon: int | None = None,
    orders: range | None = None,
    stable: Stable = "auto",
    sub: Subspace | None = None,
    bd: BD = "subspace",
) -> LinearModel:
    """The state-space model of ``order`` (or the best of ``orders`` by :func:`choose_order`;
    default range 1 … 10) in innovations form, with its singular values in ``parameters``
    (:class:`~elab.ident.parameters.N4sidParameters`).

    ``bd``: B and D from the R factor (N4SID, as SLICOT) or by the simulation least
    squares (jointly with x₀). ``stable``: what to do with poles of the estimate outside
    the unit circle — ``False`` keeps them, ``True`` reflects them into it (λ → 1/λ̄, the
    others stay), ``"auto"`` keeps whichever of the two fits the estimation data better
    (simulated from its estimated initial state), and both fits are in ``parameters``."""
    if bd not in BD_METHODS:
        raise InvalidInput("bd", bd, " or ".join(repr(b) for b in BD_METHODS))
    if stable not in (False, True, "auto"):
        raise InvalidInput("stable", stable, "false, true or 'auto'")
    sub = decompose(data, horizon) if sub is None else sub
    if order is None:
        order = choose_order(sub, orders or range(1, 11), bd, stable).best
    if not isinstance(order, int) or isinstance(order, bool) or not 1 <= order <= sub.max_order:
        raise InvalidInput(
            "order",
            order,
            f"an integer in 1 … {sub.max_order} for horizon {sub.horizon} (order < horizon)",
        )
    f = _fitted(sub, order, stable, bd)
    A, B, C, D = f.A, f.B, f.C, f.D
    K, lam, riccati = _kalman_gain(sub, A, B, C, D)
    parameters = N4sidParameters(
        order=order,
        horizon=sub.horizon,
        singular_values=sub.singular_values,
        x0=f.x0,
        bd=bd,
        reflected=f.moved,
        choice=f.choice,
        kalman=riccati,
    )
    return LinearModel(A, B, C, D, K, data.Ts, lam, parameters)


@dataclass(frozen=True)
class OrderRow:
    """One order's figures: the mean squared simulation error on the estimation data
    (x₀ estimated), the criteria log V + penalty, and the fit [%] of the record's last
    third by the model of its first two thirds (NaN where not checked; see
    :func:`choose_order`)."""

    order: int
    loss: float
    mdl: float
    aic: float
    holdout: float = math.nan


@dataclass(frozen=True)
class OrderChoice:
    """The order :func:`choose_order` chose for ``horizon``, why, every order's figures
    and the singular values."""

    best: int
    reason: str
    rows: tuple[OrderRow, ...]
    horizon: int
    singular_values: Array


HOLDOUT = 1 / 3  # the share of the record the order is checked on (the last)


def choose_order(
    sub: Subspace, orders: range, bd: BD = "subspace", stable: Stable = "auto"
) -> OrderChoice:
    """The order over ``orders``, every order's figures, and why it was chosen.

    1. A gap in the singular values decides when there is one: the order after which
       they fall :data:`GAP` times or more (the largest such fall).
    2. Otherwise cross-validation (Ljung 1999, sec. 16.4) where the record supports it:
       models of each order from the first two thirds of the record (detrended, at the
       horizon :func:`decompose` gives that part) simulate its last third from rest, and
       the order whose simulation fits best wins. A record supports it when an input
       moves in the last third and the first two thirds can be decomposed.
    3. Otherwise the least MDL = log V + d log(N) / N, where V is the mean squared
       simulation error on the data (x₀ estimated) and d = n (2 ny + nu) + ny nu the free
       parameters; AIC = log V + 2 d / N, which penalises less, is in the rows and the
       reason too (MDL is consistent for the order, AIC tends to overfit it). The losses
       are of the models as estimated: an order whose estimate has a pole outside the
       unit circle should not win by its reflection.

    (On thirteen public data sets MDL chose an order whose validation fit was 2–8 points
    below the best order's on five — robot arm, heating system, glass furnace, ball and
    beam, evaporator — and cross-validation on two: the glass furnace, 2.3, and the
    industrial dryer, 2.7, whose orders all fit below 17 %; the heating system's last
    third holds its input constant, and MDL decides there. MDL alone picked 10 at one
    horizon and 6 at another for data whose singular values fall 100× after order 4.)"""
    data = sub.data
    top = sub.max_order
    valid = [n for n in orders if 1 <= n <= top]
    if not valid:
        raise InvalidInput(
            "orders",
            f"{orders.start} … {orders.stop - 1}",
            f"orders in 1 … {top} for horizon {sub.horizon}",
        )
    held, check_horizon = _holdout_fits(data, valid, bd, stable)
    rows = []
    for n in valid:
        V = _fitted(sub, n, False, bd).loss
        d = n * (2 * data.ny + data.nu) + data.ny * data.nu
        logV = math.log(max(V, 1e-300)) if math.isfinite(V) else math.inf
        rows.append(
            OrderRow(
                order=n,
                loss=V,
                mdl=logV + d * math.log(data.N) / data.N,
                aic=logV + 2 * d / data.N,
                holdout=held.get(n, math.nan),
            )
        )
    best = min(rows, key=lambda r: r.mdl).order
    aic = min(rows, key=lambda r: r.aic).order
    others = f"MDL {best}, AIC {aic}"
    sv = sub.singular_values
    falls = {n: sv[n - 1] / sv[n] for n in valid if n < sv.size and sv[n] > 0}
    if falls and max(falls.values()) >= GAP:
        gap = max(falls, key=lambda n: falls[n])
        why = f"the singular values fall {falls[gap]:.3g}× after order {gap} ({others})"
        return OrderChoice(gap, why, tuple(rows), sub.horizon, sv)
    if held:
        n = max(held, key=lambda k: held[k])
        why = (
            f"the best fit of the record's last third simulated from rest, {held[n]:.1f} %, "
            f"by the models of its first two thirds (horizon {check_horizon}; no fall of "
            f"the singular values of {GAP:g}× or more; {others})"
        )
        return OrderChoice(n, why, tuple(rows), sub.horizon, sv)
    why = (
        f"least MDL (no fall of the singular values of {GAP:g}× or more, and the record's "
        f"last third cannot check the orders: {check_horizon}; AIC: {aic})"
    )
    return OrderChoice(best, why, tuple(rows), sub.horizon, sv)


def _holdout_fits(
    data: IdData, orders: list[int], bd: BD, stable: Stable
) -> tuple[dict[int, float], int | str]:
    """Each order's fit [%] (mean over the outputs) of the record's last third,
    simulated from rest by the model of its first two thirds, and that model's horizon;
    or no fits and why."""
    k = int(data.N * (1 - HOLDOUT))
    first, last = data[:k].detrend(), data[k:].detrend()
    if not np.any(np.ptp(last.u, axis=0) > 1e-12 * max(float(np.max(np.abs(data.u))), 1e-300)):
        return {}, "its inputs do not move"
    try:
        part = decompose(first)
    except InvalidInput as exc:
        return {}, f"the first two thirds cannot be decomposed ({exc})"
    fits = {}
    spread = np.linalg.norm(last.y - last.y.mean(axis=0), axis=0)
    for n in (n for n in orders if n <= part.max_order):
        f = _fitted(part, n, stable, bd)
        err = np.linalg.norm(last.y - simulate(f.A, f.B, f.C, f.D, np.zeros(n), last.u), axis=0)
        fit = 100 * (1 - err / np.where(spread > 0, spread, np.inf))
        fits[n] = float(np.mean(fit)) if np.all(np.isfinite(fit)) else -math.inf
    return fits, part.horizon


@dataclass(frozen=True)
class _Fitted:
    A: Array
    B: Array
    C: Array
    D: Array
    x0: Array
    loss: float  # mean squared simulation error on the estimation data, x₀ estimated
    moved: tuple[tuple[float, float], ...]
    choice: UnstableChoice | None


def _fitted(sub: Subspace, n: int, stable: Stable, bd: BD) -> _Fitted:
    """The model of order ``n`` under the ``stable`` policy (see :func:`n4sid`).

    The estimate and its reflection both take B, D and x₀ by ``bd``, so that "auto"
    compares two sets of poles, not two ways to B and D. (Refitting the reflection's B, D
    and x₀ by the simulation least squares fitted the estimation data better nearly
    always, and the validation data worse where SLICOT's unreflected estimate was
    nearly stable: heating_system's order 10, |z| = 1.0035, 2.5 points below it.)"""
    kept = _model(sub, *_shift(sub, n, False), bd)
    if stable is False or np.max(np.abs(np.linalg.eigvals(kept.A))) <= 1.0:
        return kept
    reflected = _model(sub, *_shift(sub, n, True), bd)
    if stable is True:
        return reflected
    fits = UnstableChoice(_fit_of(sub, kept.loss), _fit_of(sub, reflected.loss))
    better = reflected if reflected.loss < kept.loss or not np.isfinite(kept.loss) else kept
    return replace(better, choice=fits)


def _model(
    sub: Subspace, A: Array, C: Array, moved: tuple[tuple[float, float], ...], bd: BD
) -> _Fitted:
    B, D, x0, err = _bdx0(sub, A, C, bd)
    with np.errstate(over="ignore"):  # an unstable candidate's error may square past 1e308
        loss = float(np.mean(err**2)) if np.all(np.isfinite(err)) else math.inf
    return _Fitted(A, B, C, D, x0, loss, moved, None)


def _fit_of(sub: Subspace, loss: float) -> float:
    """The fit % (all outputs together) a mean squared error gives on the estimation data."""
    spread = float(np.mean((sub.data.y - sub.data.y.mean(axis=0)) ** 2))
    return 100 * (1 - math.sqrt(loss / spread)) if math.isfinite(loss) and spread > 0 else -math.inf


def _shift(
    sub: Subspace, n: int, stable: bool
) -> tuple[Array, Array, tuple[tuple[float, float], ...]]:
    """A and C from the shift structure; with ``stable``, A's poles outside the unit
    circle reflected into it (the moved ones' |z| before and after are returned)."""
    ny = sub.data.ny
    G = sub.U1[:, :n] * np.sqrt(sub.singular_values[:n])
    C = G[:ny]
    A = np.linalg.lstsq(G[:-ny], G[ny:], rcond=None)[0]
    moved: tuple[tuple[float, float], ...] = ()
    if stable:
        lam, V = np.linalg.eig(A)
        out = np.abs(lam) > 1.0
        if out.any():
            moved = tuple((float(abs(z)), float(1 / abs(z))) for z in lam[out])
            lam = np.where(out, 1.0 / np.conj(lam), lam)
            A = np.real(V @ np.diag(lam) @ np.linalg.inv(V))  # conjugate pairs stay pairs
    return np.asarray(A, dtype=np.float64), C, moved


def _bdx0(sub: Subspace, A: Array, C: Array, bd: BD) -> tuple[Array, Array, Array, Array]:
    """B, D and the estimation record's x₀ by ``bd``'s method, and the simulation error
    from that x₀ (one simulation: the error from rest less the free response)."""
    u, y = sub.data.u, sub.data.y
    if bd == "simulation":
        B, D, x0 = simulation_bd(sub.data, A, C)
        return B, D, x0, y - simulate(A, B, C, D, x0, u)
    B, D = subspace_bd(sub, A, C)
    with np.errstate(over="ignore", invalid="ignore"):
        Ob = observability(A, C, sub.data.N)  # once for the three
        free = y - simulate(A, B, C, D, np.zeros(A.shape[0]), u, Ob)
        x0 = initial_state(A, C, free, Ob)
        return B, D, x0, free - Ob @ x0


def _kalman_gain(
    sub: Subspace, A: Array, B: Array, C: Array, D: Array
) -> tuple[Array, Array, Literal["riccati", "none"]]:
    """K of the steady-state Kalman filter for the covariances of the residuals of the
    state equations on X̂ = Γ_s⁺ (Γ_s X̂), the innovation covariance, and how K was had:
    "riccati", or "none" (no stabilising solution: K = 0, an output-error model)."""
    import scipy.linalg  # here: the web process imports this module, not scipy

    data, s, n = sub.data, sub.horizon, A.shape[0]
    ny = data.ny
    # Γ_s = U₁ Σ₁^½ has orthogonal columns: X̂ = Γ_s⁺ (Γ_s X̂) = Σ₁^−½ U₁ᵀ (Γ_s X̂)
    X = (sub.states_map[:n] / np.sqrt(sub.singular_values[:n])[:, None]) @ _past(data, s)
    j = X.shape[1]
    U, Y = data.u[s : s + j].T, data.y[s : s + j].T
    W = X[:, 1:] - A @ X[:, :-1] - B @ U[:, :-1]
    V = Y - C @ X - D @ U
    V = V[:, :-1]
    m = W.shape[1]
    Q, S, Rv = W @ W.T / m, W @ V.T / m, V @ V.T / m

    def gain(P: Array) -> tuple[Array, Array]:
        Re = C @ P @ C.T + Rv
        K = (A @ P @ C.T + S) @ np.linalg.inv(Re)
        if not np.all(np.isfinite(K)) or np.max(np.abs(np.linalg.eigvals(A - K @ C))) >= 1:
            raise np.linalg.LinAlgError("unstable predictor")
        return K, Re

    # the doubling first; scipy's QZ solver where it gives nothing or an unstable predictor
    solvers = (
        lambda: filter_dare(A, C, Q, Rv, S),
        lambda: scipy.linalg.solve_discrete_are(A.T, C.T, Q, Rv, s=S),
    )
    for solve in solvers:
        try:
            P = solve()
            if P is not None:
                return *gain(P), "riccati"
        except (np.linalg.LinAlgError, ValueError):
            pass
    return np.zeros((n, ny)), Rv, "none"  # an output-error model: the predictor simulates


DARE_TOL = 1e-13  # relative change of the doubling's iterate at which it has converged
DARE_STEPS = 64  # doublings at most (each squares the horizon: 2⁶⁴ steps of the filter)
DARE_RESIDUAL = 1e-9  # a converged P that leaves more of the equation unsolved is refused


def filter_dare(A: Array, C: Array, Q: Array, R: Array, S: Array) -> Array | None:
    """The stabilising P of the filter's Riccati equation
    P = A P Aᵀ − (A P Cᵀ + S)(C P Cᵀ + R)⁻¹(A P Cᵀ + S)ᵀ + Q by the structured doubling
    algorithm (Chu, Fan and Lin 2005; the cross term S removed first), or None where it
    does not converge (then scipy's QZ solver decides). It is plain small-matrix
    arithmetic, a few doublings: 0.2–0.3 ms a call on the public sets' models (1 to 10
    states), against scipy's 0.9–2.2 ms on a slow host; about a tenth of a small subspace
    identification."""
    from scipy.linalg import lapack  # LAPACK's solver as numpy's, without its checks

    try:
        Ri = np.linalg.inv(R)
        F = A - S @ Ri @ C
        H = Q - S @ Ri @ S.T  # Q̄ ≥ 0: the Schur complement of a covariance
        G = C.T @ Ri @ C
        Ak = F.T
        n = A.shape[0]
        eye = np.eye(n)
        with np.errstate(all="ignore"):
            for _ in range(DARE_STEPS):
                W, info = lapack.dgesv(eye + G @ H, np.hstack([Ak, G]))[2:]
                if info != 0:
                    return None  # a singular step
                WA, WG = W[:, :n], W[:, n:]
                H_next = H + Ak.T @ H @ WA
                G = G + Ak @ WG @ Ak.T
                Ak = Ak @ WA
                size = float(np.abs(H_next).sum(axis=0).max())  # the 1-norm
                if not math.isfinite(size):
                    return None
                if float(np.abs(H_next - H).sum(axis=0).max()) <= DARE_TOL * size:
                    P = (H_next + H_next.T) / 2
                    return P if _dare_residual(A, C, Q, R, S, P) <= DARE_RESIDUAL else None
                H = H_next
    except np.linalg.LinAlgError:
        return None
    return None


def _dare_residual(A: Array, C: Array, Q: Array, R: Array, S: Array, P: Array) -> float:
    """How far P is from solving the filter's Riccati equation, relative to its terms."""
    L = A @ P @ C.T + S
    rhs = A @ P @ A.T - L @ np.linalg.solve(C @ P @ C.T + R, L.T) + Q
    scale = max(float(np.linalg.norm(P, 1)), float(np.linalg.norm(Q, 1)), 1e-300)
    return float(np.linalg.norm(P - rhs, 1)) / scale
