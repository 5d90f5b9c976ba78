"""State-feedback synthesis: LQR and pole placement, with the convention :math:`u = -Kx`.

Inputs are checked before python-control is called, so a bad weight or an
uncontrollable plant is reported in words rather than as a solver failure.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np

from elab.design._checks import (
    ComplexVector,
    Matrix,
    columns,
    complex_vector,
    readonly,
    sort_eigenvalues,
    square,
)
from elab.design.analysis import controllability
from elab.errors import DimensionError, InvalidInput
from elab.plants import Plant
from elab.validate import finite_array

_SYMMETRY_TOL = 1e-12  # relative
_MODE_TOL = 1e-9  # relative to ||A||: eigenvalue on the axis, PBH rank deficiency

MAX_POLE = 1e6  # rad/s: the largest pole |p| place() accepts


@dataclass(frozen=True)
class LQR:
    """Optimal gain ``K`` (nu, nx), Riccati solution ``S`` (nx, nx), poles of A − BK."""

    K: Matrix
    S: Matrix
    poles: ComplexVector


def lqr(A: Any, B: Any, Q: Any, R: Any) -> LQR:
    """Linear-quadratic regulator for :math:`\\dot x = Ax + Bu`.

    .. math::
        \\min_u \\int_0^\\infty (x^T Q x + u^T R u)\\, dt, \\qquad u = -Kx,\\quad K = R^{-1} B^T S,

        A^T S + S A - S B R^{-1} B^T S + Q = 0

    Parameters
    ----------
    A : array_like, shape (nx, nx)
    B : array_like, shape (nx, nu)
    Q : array_like, shape (nx,) or (nx, nx)
        State weight: the diagonal, or a symmetric positive semidefinite matrix.
    R : float or array_like, shape (nu,) or (nu, nu)
        Input weight: a scalar (times the identity), the diagonal, or a symmetric
        positive definite matrix.

    Raises
    ------
    InvalidInput
        For weights of the wrong shape or sign, an unstabilisable (A, B), or a
        mode on the imaginary axis that Q does not see (no stabilising solution).

    References
    ----------
    B. D. O. Anderson and J. B. Moore, *Optimal Control: Linear Quadratic Methods*, 1990, §3.3;
    K. Zhou, J. C. Doyle and K. Glover, *Robust and Optimal Control*, 1996, Cor. 13.8.
    """
    return _regulator(A, B, Q, R, discrete=False)


def dlqr(A: Any, B: Any, Q: Any, R: Any) -> LQR:
    """Linear-quadratic regulator for the discrete system :math:`x_{k+1} = Ax_k + Bu_k`.

    .. math::
        \\min_u \\sum_{k=0}^\\infty (x_k^T Q x_k + u_k^T R u_k), \\qquad u_k = -Kx_k,\\quad
        K = (R + B^T S B)^{-1} B^T S A,

        S = A^T S A - A^T S B (R + B^T S B)^{-1} B^T S A + Q

    Parameters and errors as :func:`lqr`, with the unit circle for the imaginary axis:
    every mode with :math:`|\\lambda| \\ge 1` must be controllable, and Q must see every
    mode on the unit circle.

    References
    ----------
    G. F. Franklin, J. D. Powell and M. Workman, *Digital Control of Dynamic Systems*,
    3rd ed., 1998, §9.3.
    """
    return _regulator(A, B, Q, R, discrete=True)


def _regulator(A: Any, B: Any, Q: Any, R: Any, *, discrete: bool) -> LQR:
    """:func:`lqr` or :func:`dlqr`: the checks, python-control's solver, the poles."""
    A = square("A", A)
    B = columns("B", B, A.shape[0])
    Q = _weight("Q", Q, A.shape[0], definite=False)
    R = _weight("R", R, B.shape[1], definite=True)
    _check_modes(A, B, Q, discrete=discrete)
    # the discrete solver says ValueError where the continuous one says LinAlgError
    failures = (np.linalg.LinAlgError, ValueError) if discrete else (np.linalg.LinAlgError,)
    try:
        with np.errstate(all="ignore"):  # weights near the float range: the solver says so
            K, S, _ = (ct.dlqr if discrete else ct.lqr)(A, B, Q, R)
    except failures as exc:
        raise InvalidInput(
            "Q, R", (Q, R), f"weights for which the Riccati equation is solvable (solver: {exc})"
        ) from exc
    K = np.asarray(K, dtype=np.float64).reshape(B.shape[1], A.shape[0])
    poles = sort_eigenvalues(np.linalg.eigvals(A - B @ K))
    return LQR(readonly(K), readonly(np.asarray(S, dtype=np.float64)), readonly(poles))


def _weight(field: str, value: Any, n: int, *, definite: bool) -> Matrix:
    kind = "positive definite" if definite else "positive semidefinite"
    diagonal = f"its diagonal ({n} numbers), " if n > 1 else ""
    allowed = f"a symmetric {kind} {n}×{n} matrix, {diagonal}or one number (times the identity)"
    W = finite_array(field, value)
    if W.ndim == 0:
        W = W * np.eye(n)
    elif W.ndim == 1 and W.size == n:
        W = np.diag(W)
    if W.shape != (n, n):
        raise DimensionError(field, value, f"{allowed}, got shape {W.shape}")
    largest = float(np.max(np.abs(W)))
    if np.max(np.abs(W - W.T)) > _SYMMETRY_TOL * largest:
        raise InvalidInput(field, value, f"{allowed}; this one is not symmetric")
    eigenvalues = np.linalg.eigvalsh(W / 2 + W.T / 2)  # not (W + W.T) / 2: no overflow
    floor = _SYMMETRY_TOL * float(np.max(np.abs(eigenvalues)))
    if eigenvalues[0] < -floor or (definite and eigenvalues[0] <= floor):
        raise InvalidInput(
            field, value, f"{allowed}; its smallest eigenvalue is {eigenvalues[0]:.4g}"
        )
    if not np.array_equal(W, W.T):  # symmetric within the tolerance, relative to its size:
        W = W / 2 + W.T / 2  # python-control's test is absolute (Q[0][1] = 9e18 beside 1e308)
    return W


def _check_modes(A: Matrix, B: Matrix, Q: Matrix, *, discrete: bool = False) -> None:
    """PBH eigenvector tests: no mode with Re ≥ 0 (``discrete``: |λ| ≥ 1) hidden from B,
    none on the axis (the unit circle) hidden from Q.

    A mode λ is hidden from B if some left eigenvector :math:`w^H (A - λI) = 0`
    has :math:`w^H B = 0`, and hidden from Q if some eigenvector has :math:`Qv = 0`.
    """
    n = A.shape[0]
    scale = float(np.linalg.norm(A, 2)) or 1.0
    for lam in np.unique(np.linalg.eigvals(A)):
        # distance into the stable region: left of the axis, inside the unit circle
        inside = 1.0 - abs(lam) if discrete else -lam.real
        if inside > _MODE_TOL * (1.0 if discrete else scale):
            continue
        shifted = A - lam * np.eye(n)
        W = _null_space(shifted.conj().T, scale)
        if _hides(W.conj().T @ B, W.shape[1], B):
            raise InvalidInput(
                "A, B",
                f"an uncontrollable mode λ = {_text(lam)}",
                "a stabilisable pair: every mode outside the open "
                + ("unit disc" if discrete else "left half-plane")
                + " must be controllable (PBH test)",
            )
        V = _null_space(shifted, scale)
        if abs(inside) <= _MODE_TOL * (1.0 if discrete else scale) and _hides(Q @ V, V.shape[1], Q):
            raise InvalidInput(
                "Q",
                Q,
                f"a weight that penalises every mode of A on the "
                f"{'unit circle' if discrete else 'imaginary axis'}; Q does not see the "
                f"mode λ = {_text(lam)}, "
                "so the Riccati equation has no stabilising solution",
            )


def _text(lam: complex) -> str:
    return f"{lam.real:.4g}" if lam.imag == 0 else f"{lam.real:.4g}{lam.imag:+.4g}j"


def _null_space(M: Any, scale: float) -> Any:
    """Orthonormal columns spanning the v with ``M v ≈ 0`` (at least the smallest one)."""
    _, sigma, Vh = np.linalg.svd(M)
    keep = sigma <= _MODE_TOL * scale
    keep[-1] = True
    return Vh[keep].conj().T


def _hides(projected: Any, k: int, reference: Matrix) -> bool:
    """Whether ``projected`` (image of k null vectors) has rank < k, relative to ‖reference‖."""
    sigma = np.linalg.svd(projected, compute_uv=False)
    floor = _MODE_TOL * float(np.linalg.norm(reference, 2))
    return int(np.sum(sigma > floor)) < k


@dataclass(frozen=True)
class Placement:
    """Gain ``K`` (nu, nx) and the poles of A − BK it achieves (recomputed)."""

    K: Matrix
    poles: ComplexVector


def place(A: Any, B: Any, poles: Any) -> Placement:
    """State feedback :math:`u = -Kx` that puts the eigenvalues of :math:`A - BK` at ``poles``.

    .. math:: \\operatorname{eig}(A - BK) = \\{p_1, \\dots, p_n\\}

    Uses python-control's ``place`` (Kautsky–Nichols–Van Dooren robust
    placement); a pole repeated more often than rank B falls back to
    Ackermann's formula for a single input.

    Raises
    ------
    InvalidInput
        If the number of poles is not nx, complex poles are not in conjugate
        pairs, or (A, B) is not controllable.

    References
    ----------
    J. Kautsky, N. K. Nichols and P. Van Dooren, "Robust pole assignment in linear
    state feedback", *Int. J. Control* 41(5), 1985.
    """
    A = square("A", A)
    B = columns("B", B, A.shape[0])
    p = _conjugate_pairs(complex_vector("poles", poles), A.shape[0])
    if np.max(np.abs(p)) > MAX_POLE:
        raise InvalidInput(
            "poles",
            poles,
            f"poles with |p| ≤ {MAX_POLE:g} rad/s (beyond, the gains overflow double precision)",
        )
    report = controllability(A, B)
    if not report.full:
        raise InvalidInput(
            "A, B",
            f"a pair with controllability rank {report.rank} < {A.shape[0]}",
            "a controllable (A, B) pair",
        )
    if np.max(np.unique(p, return_counts=True)[1]) > np.linalg.matrix_rank(B):
        if B.shape[1] != 1:
            raise InvalidInput(
                "poles",
                poles,
                f"each pole repeated at most rank B = {np.linalg.matrix_rank(B)} times",
            )
        K = _placed(ct.acker, A, B, p, poles)
    else:
        K = _placed(ct.place, A, B, p, poles)
    K = np.asarray(K, dtype=np.float64).reshape(B.shape[1], A.shape[0])
    return Placement(readonly(K), readonly(sort_eigenvalues(np.linalg.eigvals(A - B @ K))))


def _placed(method: Any, A: Matrix, B: Matrix, p: ComplexVector, poles: Any) -> Any:
    """``method(A, B, p)``, with a numerical failure (far or clustered poles) as the poles'
    fault: python-control raises LinAlgError or ValueError, or returns non-finite gains."""
    try:
        with np.errstate(all="ignore"):
            K = method(A, B, p)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise InvalidInput("poles", poles, f"poles that can be placed ({exc})") from None
    if not np.all(np.isfinite(K)):
        raise InvalidInput("poles", poles, "poles whose gains are finite numbers")
    return K


def _conjugate_pairs(p: ComplexVector, n: int) -> ComplexVector:
    """``p`` with real poles made exactly real and each complex pair exactly conjugate."""
    if p.size != n:
        raise DimensionError("poles", p, f"{n} poles, one per state")
    tol = 1e-9 * np.maximum(np.abs(p), 1.0)
    p = np.where(np.abs(p.imag) <= tol, p.real + 0j, p)
    upper, lower = p[p.imag > 0], p[p.imag < 0]
    matched = upper.size == lower.size and np.allclose(
        np.sort_complex(upper), np.sort_complex(np.conj(lower)), rtol=1e-9, atol=0
    )
    if not matched:
        raise InvalidInput("poles", p, "real poles and complex poles in conjugate pairs")
    upper = np.sort_complex(upper)
    return np.concatenate([p[p.imag == 0], upper, np.conj(upper)])


def design_lqr(plant: Plant, Q: Any, R: Any) -> LQR:
    """:func:`lqr` on the plant's ``A`` and ``B`` (gain for :class:`elab.laws.StateFeedback`).

    .. math:: u = -Kx = K(x_{ref} - x) \\text{ with } x_{ref} = 0

    References
    ----------
    Seed chapter eq. 4.6 (flexible link: Q = diag(400, 10000, 3, 2), R = 1).
    """
    return lqr(plant.A, plant.B, Q, R)


def design_place(plant: Plant, poles: Any) -> Placement:
    """:func:`place` on the plant's ``A`` and ``B``.

    .. math:: \\operatorname{eig}(A - BK) = \\{p_1, \\dots, p_n\\}

    References
    ----------
    Seed chapter §4.1.3 (controller design by LQR or pole placement).
    """
    return place(plant.A, plant.B, poles)
