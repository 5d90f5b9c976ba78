"""The one form every identified model takes: a discrete innovations state space

    x(t+1) = A x(t) + B u(t) + K e(t)
    y(t)   = C x(t) + D u(t) + e(t),        E e eᵀ = Λ

(Ljung 1999, sec. 4.3). ARX, ARMAX, OE and subspace models each convert to it, so
simulation, k-step prediction, comparison, residual analysis and the hand-over to the
design tools (python-control) are written once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, assert_never

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData
from elab.ident.parameters import (
    ArmaxParameters,
    ArxParameters,
    LinkParameters,
    MimoArxParameters,
    ModelParameters,
    N4sidParameters,
    OeParameters,
)
from elab.lti import StateSpaceShape

if TYPE_CHECKING:  # imported where used: python-control costs about a second of imports
    import control as ct

Array = NDArray[np.float64]
X0_RCOND = 1e-8  # singular values of the observability matrix below this share are cut
X0_GROWTH = 1e100  # an unstable model's free response is fitted while Aᵗ grows less
MODAL_COND = 1e10  # x₀ is fitted in modal coordinates too where A's eigenvectors allow
MODAL_ROWS = 200_000  # samples the modal fit uses, at most (its matrix is complex)
MODE_FLOOR = 1e-20  # a mode this far decayed from its start is zero to the fit


def observability(A: Array, C: Array, N: int) -> Array:
    """C Aᵗ for t = 0 … N−1, shape (N, ny, n), in blocks of doubling length."""
    ny, n = C.shape
    out = np.empty((N, ny, n))
    out[0] = C
    filled, P = 1, A.copy()  # P = A^filled
    while filled < N:
        m = min(filled, N - filled)
        out[filled : filled + m] = out[:m] @ P
        filled += m
        P = P @ P if filled < N else P
    return out


def initial_state(A: Array, C: Array, free: Array, Ob: Array | None = None) -> Array:
    """x₀ minimising ‖free(t) − C Aᵗ x₀‖ over the data, well-conditioned: the singular
    directions of the observability matrix below :data:`X0_RCOND` of the largest are left
    out (the minimum-norm solution, not one that trades a huge x₀ against noise). An
    unstable model is fitted over the samples where Aᵗ stays below :data:`X0_GROWTH`
    (beyond them its simulation overflows), and samples whose free response is not
    finite are left out. ``Ob``: :func:`observability` over the data where the caller
    has it."""
    N, n = free.shape[0], A.shape[0]
    if n == 0 or N == 0:
        return np.zeros(n)
    rho = float(np.max(np.abs(np.linalg.eigvals(A))))
    T = N if rho <= 1.0 else max(n, min(N, int(math.log(X0_GROWTH) / math.log(rho))))
    if Ob is None:
        with np.errstate(over="ignore", invalid="ignore"):
            Ob = observability(A, C, T)
    return _modal_refit(A, C, free[:T], fit_state(Ob[:T], free[:T]))


def _modal_refit(A: Array, C: Array, free: Array, x0: Array) -> Array:
    """``x0``, or the x₀ fitted on the modes λᵢᵗ (C vᵢ) where that fits ``free`` better.
    Powers of A by repeated squaring lose the free response to round-off when A's own
    basis is ill-conditioned: an ARX model's companion form of an integrating plant at
    1 kHz, fitted on 30,000 samples, "fitted" data it had simulated itself at −2,000 %.
    The modes are powers of numbers, exact to round-off, and both candidates are judged
    on them."""
    lam, V = np.linalg.eig(A)
    if not np.all(np.isfinite(lam)) or np.linalg.cond(V) > MODAL_COND:
        return x0
    # both candidates judged on the same samples; where every mode has decayed below
    # MODE_FLOOR its rows of the fit are zeros, adding the same Σ free² to both misfits
    # and nothing to the least squares: they are left out (a stable model of 10,000
    # samples is fitted on its first few hundred)
    rho = float(np.max(np.abs(lam)))
    alive = MODAL_ROWS if rho >= 1 else 1 if rho == 0 else int(math.log(MODE_FLOOR) / math.log(rho))
    free = free[: max(min(MODAL_ROWS, alive + 1), A.shape[0])]
    T, n = free.shape[0], A.shape[0]
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        modes = _powers(lam, T)
    ok = np.isfinite(free).all(axis=1) & np.isfinite(modes).all(axis=1)
    if not ok.any():
        return x0
    M = (modes[ok][:, None, :] * (C @ V)[None, :, :]).reshape(-1, n)
    f = free[ok].reshape(-1)
    xi, *_ = np.linalg.lstsq(M, f.astype(complex), rcond=X0_RCOND)  # rows finite: see ok
    modal = np.real(V @ xi)

    def misfit(x: Array) -> float:
        with np.errstate(over="ignore", invalid="ignore"):
            r = f - np.real(M @ np.linalg.solve(V, x.astype(complex)))
            e = float(r @ r)
        return e if math.isfinite(e) else math.inf

    return modal if misfit(modal) < misfit(x0) else x0


def _powers(lam: NDArray[np.complex128], T: int) -> NDArray[np.complex128]:
    """λᵢᵗ for t = 0 … T−1, (T, n): a real λ's as a real power with its sign (exact to
    round-off), a complex one's as |λ|ᵗ e^{itθ}. Numpy's complex power is ten times
    slower (2 ms of a 12 ms subspace identification at 2,000 samples)."""
    t = np.arange(T, dtype=np.float64)[:, None]
    mag = np.abs(lam)[None, :] ** t
    out = mag.astype(np.complex128)
    negative = (lam.imag == 0) & (lam.real < 0)
    out[1::2, negative] *= -1.0  # exact ±1
    turning = lam.imag != 0
    if turning.any():
        angle = np.angle(lam[turning])[None, :] * t
        out[:, turning] = mag[:, turning] * (np.cos(angle) + 1j * np.sin(angle))
    return out


def fit_state(Ob: Array, free: Array) -> Array:
    """x₀ minimising ‖free(t) − Ob(t) x₀‖ (Ob: (T, ny, n)) by the truncated SVD of
    :func:`initial_state`, over the samples where both are finite."""
    n = Ob.shape[2]
    ok = np.isfinite(free).all(axis=1) & np.isfinite(Ob).all(axis=(1, 2))
    if not ok.any():
        return np.zeros(n)
    x0, *_ = np.linalg.lstsq(Ob[ok].reshape(-1, n), free[ok].reshape(-1), rcond=X0_RCOND)
    return np.asarray(x0, dtype=np.float64)


@dataclass(frozen=True)
class LinearModel(StateSpaceShape):
    """A discrete-time model in innovations form at sample time ``Ts`` (``nx`` states,
    ``nu`` inputs, ``ny`` outputs)."""

    A: Array
    B: Array
    C: Array
    D: Array
    K: Array
    Ts: float
    #: covariance Λ of the innovations e (ny × ny)
    noise_variance: Array
    #: what its estimator found besides the state space (None: a model given as one)
    parameters: ModelParameters | None = None

    def __post_init__(self) -> None:
        A = np.asarray(self.A, dtype=float)
        A = np.zeros((0, 0)) if A.size == 0 else np.atleast_2d(A)
        n = A.shape[0]
        if n == 0:  # a static model (ARX with na = 0 and one b): y = D u + e
            D = np.atleast_2d(np.asarray(self.D, dtype=float))
            ny, nu = D.shape
            B, C = np.zeros((0, nu)), np.zeros((ny, 0))
        else:
            B = np.asarray(self.B, dtype=float).reshape(n, -1)
            C = np.asarray(self.C, dtype=float).reshape(-1, n)
            ny, nu = C.shape[0], B.shape[1]
            D = np.asarray(self.D, dtype=float).reshape(ny, nu)
        K = np.asarray(self.K, dtype=float).reshape(n, ny)
        lam = np.asarray(self.noise_variance, dtype=float).reshape(ny, ny)
        for name, v in (("A", A), ("B", B), ("C", C), ("D", D), ("K", K)):
            object.__setattr__(self, name, v)
        object.__setattr__(self, "noise_variance", lam)

    @property
    def kind(self) -> Literal["arx", "armax", "oe", "n4sid", "link", "linear"]:
        """The model structure its parameters are of (``"linear"``: none, a state space)."""
        match self.parameters:
            case ArxParameters() | MimoArxParameters():
                return "arx"
            case ArmaxParameters():
                return "armax"
            case OeParameters():
                return "oe"
            case N4sidParameters():
                return "n4sid"
            case LinkParameters():
                return "link"
            case None:
                return "linear"
            case _:
                assert_never(self.parameters)

    @property
    def poles(self) -> NDArray[np.complex128]:
        return np.asarray(np.linalg.eigvals(self.A), dtype=np.complex128)

    @property
    def stable(self) -> bool:
        """Every pole strictly inside the unit circle (a static model is stable)."""
        return bool(np.all(np.abs(self.poles) < 1)) if self.nx else True

    def simulate(self, u: Array, x0: Array | None = None) -> Array:
        """Outputs for inputs ``u`` ``(N, nu)`` from state ``x0`` (default 0), no noise."""
        u = self._inputs(u)
        x = np.zeros(self.nx) if x0 is None else np.asarray(x0, dtype=float).reshape(self.nx)
        y = np.empty((u.shape[0], self.ny))
        A, B, C, D = self.A, self.B, self.C, self.D
        for t in range(u.shape[0]):
            y[t] = C @ x + D @ u[t]
            x = A @ x + B @ u[t]
        return y

    def predict(self, data: IdData, horizon: int = 1, x0: Array | None = None) -> Array:
        """``horizon``-step-ahead predictions ŷ(t | t − horizon) of ``data.y``.

        The one-step predictor runs the Kalman form x̂(t+1) = A x̂ + B u + K (y − C x̂ − D u);
        longer horizons continue from x̂(t − horizon + 1 | t − horizon) with inputs only.
        """
        if horizon < 1:
            raise InvalidInput("horizon", horizon, "an integer ≥ 1")
        u, y = self._inputs(data.u), data.y
        N = u.shape[0]
        xh = np.empty((N, self.nx))
        x = np.zeros(self.nx) if x0 is None else np.asarray(x0, dtype=float).reshape(self.nx)
        A, B, C, D, K = self.A, self.B, self.C, self.D, self.K
        for t in range(N):
            xh[t] = x
            x = A @ x + B @ u[t] + K @ (y[t] - C @ x - D @ u[t])
        if horizon == 1:
            return xh @ C.T + u @ D.T
        # x(t | t−h): start from x̂(t−h+1 | t−h) and apply h − 1 noise-free steps
        h = horizon
        X = np.zeros((N, self.nx))
        X[h - 1 :] = xh[: N - h + 1]
        for j in range(h - 1):
            idx = np.arange(h - 1, N)
            X[idx] = X[idx] @ A.T + u[idx - (h - 1) + j] @ B.T
        yh = X @ C.T + u @ D.T
        yh[: h - 1] = xh[: h - 1] @ C.T + u[: h - 1] @ D.T  # too early: one step ahead
        return yh

    def transfer_functions(self) -> list[list[tuple[Array, Array]]]:
        """The deterministic part's transfer functions Gᵢⱼ(z) = num/den, [output i][input
        j], coefficients in descending powers of z, by the matrix determinant lemma:

            Gᵢⱼ(z) = cᵢ (zI − A)⁻¹ bⱼ + dᵢⱼ
                   = (det(zI − A + bⱼ cᵢ) + (dᵢⱼ − 1) det(zI − A)) / det(zI − A)

        — the arithmetic of ``scipy.signal.ss2tf``, which python-control's ``ss2tf`` runs
        without slycot, with its trimming of leading zeros: :meth:`to_tf` gives the same
        coefficients as a python-control object, this needs no python-control.
        """
        if self.nx == 0:  # a static gain
            return [
                [(_trim(self.D[i, [j]]), np.ones(1)) for j in range(self.nu)]
                for i in range(self.ny)
            ]
        den = np.poly(self.A)  # det(zI − A)
        out = []
        for i in range(self.ny):
            row = []
            for j in range(self.nu):
                lemma = np.poly(self.A - np.outer(self.B[:, j], self.C[i]))
                row.append((_trim(lemma + (self.D[i, j] - 1) * den), _trim(den)))
            out.append(row)
        return out

    def to_control(self) -> ct.StateSpace:
        """The deterministic part (u → y) as a python-control discrete state space."""
        import control as ct

        return ct.ss(self.A, self.B, self.C, self.D, self.Ts)

    def to_tf(self) -> ct.TransferFunction:
        """:meth:`to_control` as a python-control transfer function."""
        import control as ct

        return ct.ss2tf(self.to_control())

    def _inputs(self, u: Array) -> Array:
        u = np.asarray(u, dtype=float)
        if u.ndim == 1:
            u = u[:, None]
        if u.ndim != 2 or u.shape[1] != self.nu:
            raise InvalidInput("u", f"shape {u.shape}", f"N × {self.nu} inputs")
        return u


def _trim(p: NDArray[np.floating[Any]]) -> Array:
    """``p`` without its leading zero coefficients (``[0.0]`` if all are zero)."""
    nonzero = np.flatnonzero(p)
    return np.asarray(p[nonzero[0] :] if nonzero.size else np.zeros(1), dtype=np.float64)


@dataclass(frozen=True)
class ContinuousModel:
    """ẋ = A x + B u, y = C x + D u: a discrete model's deterministic part in continuous
    time (s)."""

    A: Array
    B: Array
    C: Array
    D: Array


def d2c(m: LinearModel) -> ContinuousModel | None:
    """``m`` in continuous time by the inverse of the zero-order hold, MATLAB's ``d2c``:
    [[A, B], [0, I]] = expm(Ts [[Ac, Bc], [0, 0]]), C and D carry over. None where no real
    one exists: a pole on the negative real axis or at zero (the matrix logarithm has no
    real value there), or a static model."""
    if (
        m.nx == 0
        or np.any(np.abs(m.poles) < 1e-9)
        or np.any((np.abs(m.poles.imag) < 1e-12) & (m.poles.real < 0))
    ):
        return None
    try:
        Ac, Bc = _log_zoh(m)  # python-control 0.10 has c2d but no d2c
    except (ValueError, np.linalg.LinAlgError):
        return None
    A = np.real_if_close(Ac)
    if np.iscomplexobj(A):
        return None
    return ContinuousModel(A, Bc, m.C, m.D)


def _log_zoh(m: LinearModel) -> tuple[Array, Array]:
    """Ac, Bc of the inverse of the zero-order hold (see :func:`d2c`)."""
    import scipy.linalg  # here: the web process imports this module, not scipy

    n, nu = m.nx, m.nu
    # B by a power of two near its size (exact): logm(T M T⁻¹) = T logm(M) T⁻¹ with
    # T = diag(I, βI), and a B of 1e-50 beside an A of 1 left logm inaccurate
    norm = float(np.max(np.abs(m.B)))
    beta = math.ldexp(1.0, math.frexp(norm)[1]) if norm > 0 else 1.0
    M = np.zeros((n + nu, n + nu))
    M[:n, :n], M[:n, n:], M[n:, n:] = m.A, m.B / beta, np.eye(nu)
    L = scipy.linalg.logm(M) / m.Ts
    if np.max(np.abs(np.imag(L))) > 1e-8:
        raise ValueError("no real logarithm")
    L = np.real(L)
    return L[:n, :n], L[:n, n:] * beta
