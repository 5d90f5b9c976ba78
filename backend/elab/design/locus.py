"""The root locus of a loop: where the closed-loop poles go as the loop gain is scaled."""

from __future__ import annotations

from dataclasses import dataclass

import control as ct
import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from elab.design._checks import ComplexVector, Matrix, readonly
from elab.errors import InvalidInput

ComplexMatrix = NDArray[np.complex128]


@dataclass(frozen=True)
class RootLocus:
    """Closed-loop poles for each gain ``k`` (``gains``, ascending, 0 and 1 among them):
    ``branches[i, j]`` is branch i at ``gains[j]`` (NaN where 1 + k D = 0 or the numbers
    overflow). ``poles`` are
    the open loop's (k = 0), ``zeros`` its finite zeros, where branches end."""

    gains: Matrix
    branches: ComplexMatrix
    poles: ComplexVector
    zeros: ComplexVector


def root_locus(L: ct.StateSpace, n: int = 241, decades: float = 3.0) -> RootLocus:
    """Poles of the loop :math:`1 + k L = 0` for gains :math:`k` from 0 over
    :math:`10^{-d} … 10^{d}` (log-spaced, k = 1 included: the loop as designed).

    With :math:`L = (A, B, C, D)` (SISO, negative feedback) the closed loop at gain k is

    .. math:: A_k = A - k B (1 + k D)^{-1} C

    whose eigenvalues are sorted into branches by matching each gain's poles to the
    previous gain's (least total distance). Computed in state space, not from the
    characteristic polynomial, whose roots are ill-conditioned for discrete poles near
    z = 1.

    References
    ----------
    W. R. Evans, "Control system synthesis by root locus method", *AIEE Trans.* 69, 1950;
    G. F. Franklin, J. D. Powell and A. Emami-Naeini, *Feedback Control of Dynamic
    Systems*, 8th ed., 2019, ch. 5.
    """
    if L.ninputs != 1 or L.noutputs != 1:
        raise InvalidInput("L", f"{L.noutputs}×{L.ninputs}", "a SISO loop transfer")
    A, B, C, D = (np.asarray(m, dtype=np.float64) for m in (L.A, L.B, L.C, L.D))
    d = float(D[0, 0])
    gains = np.unique(np.concatenate([[0.0, 1.0], np.logspace(-decades, decades, n - 2)]))
    branches = np.full((A.shape[0], gains.size), np.nan + 0j)
    previous: ComplexVector | None = None
    for j, k in enumerate(gains):
        M = A - (k / (1.0 + k * d)) * (B @ C) if abs(1.0 + k * d) >= 1e-12 else None
        if M is None or not np.all(np.isfinite(M)):
            continue
        p: ComplexVector = np.asarray(
            np.linalg.eigvals(M) if A.size else np.zeros(0), dtype=np.complex128
        )
        if previous is not None and p.size:
            rows, cols = linear_sum_assignment(np.abs(previous[:, None] - p[None, :]))
            p = p[cols[np.argsort(rows)]]
        branches[:, j] = p
        previous = p
    return RootLocus(
        readonly(gains),
        readonly(branches),
        readonly(np.asarray(branches[:, 0], dtype=np.complex128).copy()),
        readonly(zeros(A, B, C, D)),
    )


def zeros(A: Matrix, B: Matrix, C: Matrix, D: Matrix) -> ComplexVector:
    """Finite invariant zeros of a SISO (A, B, C, D): the finite generalised eigenvalues of
    the Rosenbrock pencil :math:`\\begin{bmatrix} A & B \\\\ C & D \\end{bmatrix} - \\lambda
    \\begin{bmatrix} I & 0 \\\\ 0 & 0 \\end{bmatrix}`."""
    n = A.shape[0]
    if n == 0:
        return np.zeros(0, dtype=np.complex128)
    M = np.block([[A, B], [C, D]])
    N = np.zeros_like(M)
    N[:n, :n] = np.eye(n)
    with np.errstate(all="ignore"):
        values = scipy.linalg.eigvals(M, N)
    scale = max(1.0, float(np.linalg.norm(A, 2)))
    finite = values[np.isfinite(values) & (np.abs(values) < 1e8 * scale)]
    return np.asarray(finite, dtype=np.complex128)
