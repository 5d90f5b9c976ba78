"""ARMAX and output-error models by the prediction-error method (MATLAB's ``armax``, ``oe``)
for single-output, single-input data (Ljung 1999, ch. 7 and sec. 10.2).

ARMAX:  A(q) y(t) = B(q) u(t) + C(q) e(t),   ε(t, θ) = (A y − B u) / C,
OE:     y(t) = B(q)/F(q) u(t) + e(t),        ε(t, θ) = y − (B/F) u,

with B(q) = b₁ q⁻ⁿᵏ + … + b_nb q⁻ⁿᵏ⁻ⁿᵇ⁺¹ (reported with nk leading zeros, as MATLAB and
:func:`~elab.ident.polynomial.arx` do). θ̂ minimises V(θ) = (1/n) Σ ε(t, θ)² by damped
Gauss–Newton (Levenberg–Marquardt) steps from a linear start (pseudo-linear regression for
ARMAX, instrumental variables for OE): with ψ(t) = −∂ε/∂θ (Ljung 1999, eq. 10.40 ff.)

    ARMAX:  ψ = (1/C) [−y(t−1) … −y(t−na), u(t−nk) … u(t−nk−nb+1), ε(t−1) … ε(t−nc)],
    OE:     ψ = (1/F) [−ŷ(t−1) … −ŷ(t−nf), u(t−nk) … u(t−nk−nb+1)],   ŷ = (B/F) u,

the step solves (ΨᵀΨ + μ diag(ΨᵀΨ)) Δ = Ψᵀ ε, μ shrinking tenfold after a step that lowers
V and growing tenfold until one does. The filter polynomial (C, or F) is kept stable: any
root outside the unit circle is reflected to 1/z̄ after each step, as MATLAB does. ARMAX
errors count from the first sample whose regressors lie in the data (ε = 0 before);
the OE simulation starts from rest at the first sample (MATLAB's zero initial condition).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData, require_exciting
from elab.ident.models import LinearModel
from elab.ident.parameters import ArmaxParameters, OeParameters
from elab.ident.polynomial import from_polynomials, regressors

Array = NDArray[np.float64]
C_RADIUS = 0.99  # ARMAX's C keeps its roots within this radius: a stable one-step predictor


def armax(
    data: IdData, na: int, nb: int, nc: int, nk: int = 1, max_iter: int = 50, tol: float = 1e-6
) -> LinearModel:
    """The prediction-error ARMAX model A(q) y = B(q) u(t − nk) + C(q) e.

    Start (pseudo-linear regression): the residuals ê of an ARX model of orders
    [na + 3nc, nb + 3nc, nk] stand in for e, and A, B, C are the least squares of y on
    [−y lags, u lags, ê lags]. Then Gauss–Newton on Σ ε² with C kept stable; stops when a
    step lowers V by less than ``tol`` · V or after ``max_iter`` steps. The innovations
    variance reported is the loss V = (1/n) Σ ε².
    """
    import scipy.signal  # here: 0.7 s of imports that ARX and n4sid models do without

    _check_orders((("na", na, 0), ("nb", nb, 1), ("nc", nc, 1), ("nk", nk, 0)))
    _check_search(max_iter, tol)
    y, u = _siso(data, "ARMAX")
    ha, hb = na + 3 * nc, nb + 3 * nc
    start_h = max(ha, hb + nk - 1)
    N, need = data.N, start_h + ha + hb
    if need >= N:
        raise InvalidInput(
            "data",
            f"{data.N} samples",
            f"more than {need} samples for [na nb nc nk] = [{na} {nb} {nc} {nk}] "
            f"(the start is an ARX model of orders [{ha} {hb} {nk}])",
        )
    require_exciting(data.u, na + nb)
    start = max(na, nb + nk - 1)
    d = na + nb + nc
    Phi, Y = regressors(y, u, na, nb, nk, start)

    # start: pseudo-linear regression on the residuals of a high-order ARX model
    Ph, Yh = regressors(y, u, ha, hb, nk, start_h)
    e_hat = np.zeros(nc + N)  # ê(t) at nc + t; zero before sample start_h
    e_hat[nc + start_h :] = Yh - Ph @ _lstsq(Ph, Yh)
    arx_theta = np.r_[_lstsq(Phi, Y), np.zeros(nc)]
    if e_hat @ e_hat <= 1e-20 * (y @ y):  # noise-free data: C is not identifiable; start at 1
        plr = arx_theta
    else:
        E = np.column_stack([e_hat[nc + start - k : nc + N - k] for k in range(1, nc + 1)])
        plr = _lstsq(np.column_stack([Phi, E]), Y)

    def residuals(th: Array) -> Array:
        return np.asarray(
            scipy.signal.lfilter([1.0], np.r_[1.0, th[na + nb :]], Y - Phi @ th[: na + nb]),
            dtype=np.float64,
        )

    def gradient(th: Array, eps: Array) -> Array:
        lags = np.column_stack(
            [np.r_[np.zeros(k), eps[: eps.shape[0] - k]] for k in range(1, nc + 1)]
        )
        return np.asarray(
            scipy.signal.lfilter(
                [1.0], np.r_[1.0, th[na + nb :]], np.column_stack([Phi, lags]), axis=0
            ),
            dtype=np.float64,
        )

    def stabilise(th: Array) -> Array:
        c = _reflect(np.r_[1.0, th[na + nb :]], C_RADIUS)
        return np.asarray(np.r_[th[: na + nb], c[1:]], dtype=np.float64)

    starts = {"pseudo-linear regression": plr, "arx": arx_theta}
    sub = _subspace_polynomials(data, na)
    if sub is not None and na > 0:
        a_s, c_s = sub
        c_s = c_s if c_s.shape[0] == nc + 1 else np.r_[1.0, np.zeros(nc)]
        # B that fits best for A and C: ε = (A y − B u) / C is linear in B
        c_s = _reflect(c_s, C_RADIUS)
        ay = scipy.signal.lfilter(a_s, c_s, y)
        uf = scipy.signal.lfilter([1.0], c_s, u)
        upad = np.r_[np.zeros(nk + nb), uf]
        X = np.column_stack([upad[nb - j : nb - j + N] for j in range(nb)])
        starts["subspace"] = np.r_[a_s[1:], _lstsq(X[start:], ay[start:]), c_s[1:]]
    upad = np.r_[np.zeros(nk + nb), u]
    U = np.column_stack([upad[nb - j : nb - j + N] for j in range(nb)])[start:]
    for name, a in _pole_grid(na):  # B the least squares of A y on the u lags
        b = _lstsq(U, scipy.signal.lfilter(a, [1.0], y)[start:])
        for root in (0.0, 0.8, -0.8):  # C = (1 − root q⁻¹)^nc
            c = np.real(np.poly(np.full(nc, root)))
            starts[f"{name}, C roots at {root:g}"] = np.r_[a[1:], b, c[1:]]
    theta, eps, iterations, chosen, losses = _best_descent(
        starts, residuals, gradient, stabilise, max_iter, tol
    )
    n = eps.shape[0]
    loss = float(eps @ eps / n)
    a, c = np.r_[1.0, theta[:na]], np.r_[1.0, theta[na + nb :]]
    b = np.r_[np.zeros(nk), theta[na : na + nb]]
    m = from_polynomials(a, b, c, data.Ts, loss)
    return replace(
        m,
        parameters=ArmaxParameters(
            na=na,
            nb=nb,
            nc=nc,
            nk=nk,
            A=a,
            B=b,
            C=c,
            loss=loss,
            iterations=iterations,
            start=chosen,
            start_losses=losses,
            # C's roots held at the margin: the noise model wants one on the unit circle
            c_at_margin=bool(nc and np.max(np.abs(np.roots(c))) >= C_RADIUS - 1e-9),
            fpe=_fpe(loss, d, n),
            samples=n,
        ),
    )


def oe(
    data: IdData, nb: int, nf: int, nk: int = 1, max_iter: int = 50, tol: float = 1e-6
) -> LinearModel:
    """The prediction-error output-error model y = B(q)/F(q) u(t − nk) + e.

    The simulation error has local minima (an undermodelled plant with two resonances
    has one per resonance), so Gauss–Newton, with F kept stable, runs from several
    starts and the lowest loss wins: the ARX model of orders [nf, nb, nk]; that model
    refined by instrumental variables (the instruments are the inputs and the outputs
    the ARX model simulates; Ljung 1999, sec. 7.6); the Steiglitz–McBride iteration; and
    the poles of the subspace model of order nf with the B that fits them best.
    ``parameters`` name the winning start and every start's loss. As an innovations
    model it is A = F, B = B, C = F: the noise model is 1, so K = 0 and the one-step
    predictor is the simulation.
    """
    import scipy.signal  # here: 0.7 s of imports that ARX and n4sid models do without

    _check_orders((("nb", nb, 1), ("nf", nf, 1), ("nk", nk, 0)))
    _check_search(max_iter, tol)
    y, u = _siso(data, "OE")
    start = max(nf, nb + nk - 1)
    N, d = data.N, nb + nf
    if start + 2 * d >= N:
        raise InvalidInput(
            "data",
            f"{data.N} samples",
            f"more than {start + 2 * d} samples for [nb nf nk] = [{nb} {nf} {nk}] ({d} parameters)",
        )
    require_exciting(data.u, nb + nf)
    Phi, Y = regressors(y, u, nf, nb, nk, start)

    def stabilise(th: Array) -> Array:
        return np.asarray(np.r_[_reflect(np.r_[1.0, th[:nf]])[1:], th[nf:]], dtype=np.float64)

    def simulate(th: Array) -> Array:
        return np.asarray(
            scipy.signal.lfilter(np.r_[np.zeros(nk), th[nf:]], np.r_[1.0, th[:nf]], u),
            dtype=np.float64,
        )

    def residuals(th: Array) -> Array:
        return y - simulate(th)

    def gradient(th: Array, eps: Array) -> Array:
        yhat = np.r_[np.zeros(nf), y - eps]  # ŷ and u before the data: zero (at rest)
        cols = [-yhat[nf - i : nf + N - i] for i in range(1, nf + 1)]
        upad = np.r_[np.zeros(nk + nb), u]
        cols += [upad[nb - j : nb - j + N] for j in range(nb)]
        return np.asarray(
            scipy.signal.lfilter([1.0], np.r_[1.0, th[:nf]], np.column_stack(cols), axis=0),
            dtype=np.float64,
        )

    def with_b(f: Array) -> Array:
        """θ with F = ``f`` and the B that fits best for it (linear: y ≈ B (u / F))."""
        f = _reflect(f)
        x = scipy.signal.lfilter([1.0], f, u)
        xpad = np.r_[np.zeros(nk + nb), x]
        X = np.column_stack([xpad[nb - j : nb - j + N] for j in range(nb)])
        return np.asarray(np.r_[f[1:], _lstsq(X, y)], dtype=np.float64)

    arx_theta = _lstsq(Phi, Y)  # θ = [f₁ … f_nf, b₁ … b_nb]
    iv = arx_theta
    for _ in range(2):  # instrumental variables: z(t) = [−x lags, u lags], x the ARX simulation
        iv = stabilise(iv)
        Z, _ = regressors(simulate(iv), u, nf, nb, nk, start)
        iv = _lstsq(Z.T @ Phi, Z.T @ Y)
    starts = {
        "instrumental variables": iv,
        "arx": arx_theta,
        "steiglitz-mcbride": _steiglitz_mcbride(y, u, nb, nf, nk, start, arx_theta),
    }
    sub = _subspace_polynomials(data, nf)
    if sub is not None:
        starts["subspace"] = with_b(sub[0])
    for name, f in _pole_grid(nf):
        starts[name] = with_b(f)
    theta, eps, iterations, chosen, losses = _best_descent(
        starts, residuals, gradient, stabilise, max_iter, tol
    )
    loss = float(eps @ eps / N)
    f, b = np.r_[1.0, theta[:nf]], np.r_[np.zeros(nk), theta[nf:]]
    m = from_polynomials(f, b, f, data.Ts, loss)
    return replace(
        m,
        parameters=OeParameters(
            nb=nb,
            nf=nf,
            nk=nk,
            B=b,
            F=f,
            loss=loss,
            iterations=iterations,
            start=chosen,
            start_losses=losses,
            fpe=_fpe(loss, d, N),
            samples=N,
        ),
    )


def _gauss_newton(
    theta: Array,
    residuals: Callable[[Array], Array],
    gradient: Callable[[Array, Array], Array],
    stabilise: Callable[[Array], Array],
    max_iter: int,
    tol: float,
) -> tuple[Array, Array, int]:
    """Levenberg–Marquardt on V = Σ ε²: θ, ε(θ) and the number of steps taken."""
    eps = residuals(theta)
    V = float(eps @ eps)
    mu = 1e-4
    iterations = 0
    while iterations < max_iter and V > 0:
        psi = gradient(theta, eps)
        scale = np.sqrt(np.einsum("ij,ij->j", psi, psi))
        scale = np.maximum(scale, 1e-12 * max(float(scale.max()), 1e-300))
        while mu <= 1e12:
            # (ΨᵀΨ + μ S²) Δ = Ψᵀ ε as the least squares of [Ψ; √μ S] Δ ≈ [ε; 0]
            lhs = np.vstack([psi, np.diag(math.sqrt(mu) * scale)])
            delta = _lstsq(lhs, np.r_[eps, np.zeros(theta.shape[0])])
            trial = stabilise(theta + delta)
            e_trial = residuals(trial)
            V_trial = float(e_trial @ e_trial)
            if V_trial < V:
                break
            mu *= 10
        else:
            break  # no step lowers V: a minimum (to rounding)
        iterations += 1
        decrease = V - V_trial
        theta, eps, V = trial, e_trial, V_trial
        mu = max(mu / 10, 1e-12)
        if decrease <= tol * (V + decrease):
            break
    return theta, eps, iterations


def _best_descent(
    starts: dict[str, Array],
    residuals: Callable[[Array], Array],
    gradient: Callable[[Array, Array], Array],
    stabilise: Callable[[Array], Array],
    max_iter: int,
    tol: float,
) -> tuple[Array, Array, int, str, dict[str, float]]:
    """Gauss–Newton from every start; the lowest loss wins. Returns θ, ε, its steps, the
    winning start's name and every start's final loss (mean ε²)."""
    best: tuple[Array, Array, int, str] | None = None
    losses: dict[str, float] = {}
    for name, theta0 in starts.items():
        if not np.all(np.isfinite(theta0)):
            continue
        theta, eps, steps = _gauss_newton(
            stabilise(theta0), residuals, gradient, stabilise, max_iter, tol
        )
        V = float(eps @ eps)
        if not math.isfinite(V):
            continue
        losses[name] = V / eps.shape[0]
        if best is None or float(best[1] @ best[1]) > V:
            best = (theta, eps, steps, name)
    if best is None:
        raise InvalidInput("data", "every start diverged", "data a linear model can follow")
    return *best, losses


def _steiglitz_mcbride(
    y: Array, u: Array, nb: int, nf: int, nk: int, start: int, theta: Array, rounds: int = 20
) -> Array:
    """The Steiglitz–McBride iteration (Ljung 1999, sec. 10.4): ARX on the data filtered by
    1/F of the previous round, F kept stable; for output-error data with white noise its
    fixed point is near the global minimum, whatever the ARX bias."""
    import scipy.signal

    for _ in range(rounds):
        f = _reflect(np.r_[1.0, theta[:nf]])
        Phi, Y = regressors(
            scipy.signal.lfilter([1.0], f, y), scipy.signal.lfilter([1.0], f, u), nf, nb, nk, start
        )
        new = _lstsq(Phi, Y)
        if not np.all(np.isfinite(new)):
            break
        done = np.max(np.abs(new - theta)) <= 1e-9 * (1 + np.max(np.abs(theta)))
        theta = new
        if done:
            break
    return theta


GRID_ANGLES = (0.15, 0.4, 0.8, 1.3, 1.9, 2.6)  # rad/sample: a resonance to start from
GRID_REALS = (-0.5, 0.3, 0.7, 0.95)


def _pole_grid(n: int) -> list[tuple[str, Array]]:
    """Monic polynomials of degree ``n`` to start from, spread over the frequency axis:
    a resonance at |z| = 0.9 for each of :data:`GRID_ANGLES` (the other poles at 0.5), or
    for n = 1 a real pole at each of :data:`GRID_REALS`. The loss of an undermodelled
    plant has a minimum near each resonance it could follow; one start near each."""
    if n == 1:
        return [(f"pole at {r:g}", np.array([1.0, -r])) for r in GRID_REALS]
    if n < 1:
        return []
    rest = np.real(np.poly(np.full(n - 2, 0.5))) if n > 2 else np.array([1.0])
    return [
        (
            f"resonance at {w:g} rad/sample",
            np.asarray(np.convolve([1.0, -1.8 * math.cos(w), 0.81], rest), dtype=np.float64),
        )
        for w in GRID_ANGLES
    ]


def _subspace_polynomials(data: IdData, n: int) -> tuple[Array, Array] | None:
    """The subspace model of order ``n`` as polynomials: its poles' A (or F), and C from
    the poles of its predictor A − K C (None when the data cannot give one)."""
    from elab.ident.subspace import n4sid  # not at import: the CLI loads pem without it

    try:
        m = n4sid(data, n)
    except InvalidInput:
        return None
    a = np.real(np.poly(np.linalg.eigvals(m.A)))
    c = np.real(np.poly(np.linalg.eigvals(m.A - m.K @ m.C)))
    return np.asarray(a, dtype=np.float64), np.asarray(c, dtype=np.float64)


def _lstsq(M: Array, v: Array) -> Array:
    return np.asarray(np.linalg.lstsq(M, v, rcond=None)[0], dtype=np.float64)


def _reflect(p: Array, radius: float = 1.0) -> Array:
    """The monic polynomial p with each root z outside the unit circle moved to 1/z̄, and
    then any root beyond ``radius`` pulled in to it (same angle)."""
    if p.shape[0] <= 1:
        return p
    r = np.roots(p)
    out = np.abs(r) > 1
    r[out] = 1 / np.conj(r[out])
    far = np.abs(r) > radius
    if not out.any() and not far.any():
        return p
    r[far] = r[far] * (radius / np.abs(r[far]))
    return np.asarray(np.real(np.poly(r)), dtype=np.float64)


def _fpe(loss: float, d: int, n: int) -> float:
    """Akaike's final prediction error V (1 + d/n) / (1 − d/n) (Ljung 1999, sec. 16.4)."""
    return loss * (1 + d / n) / (1 - d / n)


def _siso(data: IdData, what: str) -> tuple[Array, Array]:
    if data.ny != 1 or data.nu != 1:
        raise InvalidInput(
            "data",
            f"{data.ny} outputs and {data.nu} inputs",
            f"one output and one input for {what}",
        )
    return data.y[:, 0], data.u[:, 0]


def _check_orders(orders: tuple[tuple[str, int, int], ...]) -> None:
    for name, value, low in orders:
        if not isinstance(value, int | np.integer) or isinstance(value, bool) or value < low:
            raise InvalidInput(name, value, f"an integer ≥ {low}")


def _check_search(max_iter: int, tol: float) -> None:
    if not isinstance(max_iter, int | np.integer) or isinstance(max_iter, bool) or max_iter < 0:
        raise InvalidInput("max_iter", max_iter, "an integer ≥ 0")
    if not isinstance(tol, int | float) or not math.isfinite(tol) or tol <= 0:
        raise InvalidInput("tol", tol, "a number > 0")
