"""System analysis of a continuous LTI model :math:`\\dot x = A x + B u,\\; y = C x + D u`.

Eigenvalues and the stability they imply, controllability and observability
with a numerically sound rank, and the transfer function of every output.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import control as ct
import numpy as np

from elab.design import _polynomials
from elab.design._checks import (
    ComplexVector,
    Matrix,
    columns,
    readonly,
    rows,
    shaped,
    sort_eigenvalues,
    square,
)
from elab.errors import DimensionError
from elab.plants import Plant
from elab.validate import finite_float

Verdict = Literal["asymptotically stable", "marginally stable", "unstable"]


@dataclass(frozen=True)
class Stability:
    """The eigenvalues of A (largest real part first) and the verdict they imply."""

    eigenvalues: ComplexVector
    verdict: Verdict
    reason: str


def stability(A: Any, *, tol: float = 1e-9) -> Stability:
    """Lyapunov stability of :math:`\\dot x = A x` from the eigenvalues of A.

    .. math::
        \\text{asymptotically stable} \\iff \\operatorname{Re}\\lambda_i < 0\\ \\forall i;
        \\qquad
        \\text{marginally stable} \\iff \\operatorname{Re}\\lambda_i \\le 0\\ \\forall i
        \\text{ and every } \\lambda \\text{ with } \\operatorname{Re}\\lambda = 0
        \\text{ is semisimple: } n - \\operatorname{rank}(A - \\lambda I) = m_\\lambda

    With :math:`s = \\lVert A \\rVert_2`, a real part counts as zero when
    :math:`|\\operatorname{Re}\\lambda| \\le \\text{tol}\\, s`; imaginary-axis
    eigenvalues closer than :math:`\\sqrt{\\text{tol}}\\, s` are one eigenvalue of
    multiplicity :math:`m_\\lambda`, and singular values of :math:`A - \\lambda I`
    below :math:`\\sqrt{\\text{tol}}\\, s` count as rank deficiency.

    Parameters
    ----------
    A : array_like, shape (n, n)
        System matrix (1/s).
    tol : float
        Relative tolerance for "on the imaginary axis", in (0, 1].

    Returns
    -------
    Stability

    References
    ----------
    C.-T. Chen, *Linear System Theory and Design*, 4th ed., 2013, Theorems 5.1 and 5.4.
    """
    A = square("A", A)
    tol = finite_float("tol", tol, 0.0, 1.0, lo_open=True)
    eigenvalues = readonly(sort_eigenvalues(np.linalg.eigvals(A)))
    scale = float(np.linalg.norm(A, 2)) or 1.0
    right = eigenvalues[eigenvalues.real > tol * scale]
    if right.size:
        return Stability(eigenvalues, "unstable", f"{_name(right)} in the right half-plane")
    on_axis = np.abs(eigenvalues.real) <= tol * scale
    if not on_axis.any():
        largest = f"{eigenvalues.real.max():.4g}"
        reason = f"all eigenvalues in the open left half-plane (largest real part {largest})"
        return Stability(eigenvalues, "asymptotically stable", reason)
    modes = _axis_modes(A, eigenvalues[on_axis], np.sqrt(tol) * scale)
    rest = ", all others in the open left half-plane" if not on_axis.all() else ""
    return Stability(eigenvalues, *_axis_verdict(modes, rest))


def _axis_verdict(modes: list[tuple[complex, int, int]], rest: str) -> tuple[Verdict, str]:
    defective = [(lam, m, g) for lam, m, g in modes if g < m]
    if defective:
        lam, m, g = defective[0]
        return "unstable", (
            f"eigenvalue {_number(lam)} on the imaginary axis has multiplicity {m} but "
            f"only {g} independent eigenvector{'' if g == 1 else 's'} (a Jordan block): "
            "the response grows polynomially in t"
        )
    upper = [(lam, m) for lam, m, _ in modes if lam.imag >= 0]
    multiplicity = (
        "simple"
        if all(m == 1 for _, m in upper)
        else "semisimple: " + ", ".join(f"{_number(lam)} with multiplicity {m}" for lam, m in upper)
    )
    noun = "eigenvalue" if len(modes) == 1 else "eigenvalues"
    values = ", ".join(_number(lam) for lam, _ in upper)
    return "marginally stable", f"{noun} {values} on the imaginary axis ({multiplicity}){rest}"


def _axis_modes(A: Matrix, axis: ComplexVector, tol: float) -> list[tuple[complex, int, int]]:
    """(eigenvalue, algebraic, geometric multiplicity) of each distinct eigenvalue on the axis."""
    modes = []
    remaining = list(axis)
    while remaining:
        close = [mu for mu in remaining if abs(mu - remaining[0]) <= tol]
        remaining = [mu for mu in remaining if abs(mu - remaining[0]) > tol]
        omega = float(np.mean(np.imag(close)))
        lam = complex(0.0, omega if abs(omega) > tol else 0.0)
        sigma = np.linalg.svd(A - lam * np.eye(A.shape[0]), compute_uv=False)
        modes.append((lam, len(close), int(np.sum(sigma <= tol))))
    return modes


def _number(z: complex) -> str:
    re, im = f"{z.real:.4g}", f"{abs(z.imag):.4g}"
    if z.imag == 0:
        return re
    if z.real == 0:
        return f"±{im}j"
    return f"{re}±{im}j"


def _name(values: ComplexVector) -> str:
    upper = [complex(v) for v in values if v.imag >= 0]
    noun = "eigenvalue" if len(values) == 1 else "eigenvalues"
    return f"{noun} {', '.join(_number(v) for v in upper)}"


@dataclass(frozen=True)
class RankReport:
    """Rank of a controllability or observability matrix, from its singular values."""

    matrix: Matrix
    rank: int
    singular_values: Matrix
    tol: float
    condition_number: float
    full: bool


def controllability(A: Any, B: Any) -> RankReport:
    """Controllability of :math:`(A, B)` from the rank of the Kalman matrix.

    .. math:: \\mathcal{C} = [\\,B \\;\\; AB \\;\\; \\cdots \\;\\; A^{n-1}B\\,],
              \\qquad \\text{controllable} \\iff \\operatorname{rank}\\mathcal{C} = n

    The rank counts singular values above
    :math:`\\max(\\text{shape})\\,\\varepsilon\\,\\sigma_{\\max}` (numpy's
    ``matrix_rank``); the condition number :math:`\\sigma_{\\max}/\\sigma_{\\min}`
    shows how close to uncontrollable (or how badly scaled) the pair is.

    References
    ----------
    C.-T. Chen, *Linear System Theory and Design*, 4th ed., 2013, Theorem 6.1.
    """
    A = square("A", A)
    B = columns("B", B, A.shape[0])
    return _rank_report(np.asarray(ct.ctrb(A, B), dtype=np.float64), A.shape[0])


def observability(A: Any, C: Any) -> RankReport:
    """Observability of :math:`(A, C)` from the rank of the Kalman matrix.

    .. math:: \\mathcal{O} = [\\,C;\\; CA;\\; \\cdots;\\; CA^{n-1}\\,],
              \\qquad \\text{observable} \\iff \\operatorname{rank}\\mathcal{O} = n

    Rank and condition number as in :func:`controllability`.

    References
    ----------
    C.-T. Chen, *Linear System Theory and Design*, 4th ed., 2013, Theorem 6.O1.
    """
    A = square("A", A)
    C = rows("C", C, A.shape[0])
    return _rank_report(np.asarray(ct.obsv(A, C), dtype=np.float64), A.shape[0])


def _rank_report(matrix: Matrix, n: int) -> RankReport:
    sigma = np.asarray(np.linalg.svd(matrix, compute_uv=False), dtype=np.float64)
    tol = max(matrix.shape) * np.finfo(np.float64).eps * float(sigma[0])
    rank = int(np.sum(sigma > tol))
    condition = float(sigma[0] / sigma[-1]) if sigma[-1] > 0 else float("inf")
    return RankReport(readonly(matrix), rank, readonly(sigma), tol, condition, rank == n)


@dataclass(frozen=True)
class TransferFunction:
    """:math:`G(s) = \\text{num}(s)/\\text{den}(s)` from ``input`` to ``output``.

    Coefficients in descending powers of s; ``den`` is monic.
    """

    num: Matrix
    den: Matrix
    output: str
    input: str

    def text(self, precision: int = 4) -> str:
        """Plain text, e.g. ``"(65.11 s^2 + 2.314e+04) / (s^4 + 37.02 s^3 + ...)"``."""
        num = _polynomials.text(self.num, precision)
        den = _polynomials.text(self.den, precision)
        return f"({num}) / ({den})"

    def latex(self, precision: int = 4) -> str:
        """LaTeX math, ``\\frac{num}{den}``."""
        num = _polynomials.latex(self.num, precision)
        den = _polynomials.latex(self.den, precision)
        return f"\\frac{{{num}}}{{{den}}}"


def transfer_functions(
    A: Any,
    B: Any,
    C: Any,
    D: Any,
    output_names: Sequence[str],
    input_name: str,
    *,
    rel_tol: float = 1e-9,
) -> tuple[TransferFunction, ...]:
    """The transfer function from the single input to each output, without cancellation.

    .. math:: G_i(s) = C_i (sI - A)^{-1} B + D_i
              = \\frac{\\det(sI - A + B C_i) - \\det(sI - A)}{\\det(sI - A)} + D_i

    Common poles and zeros (e.g. at the origin) are kept, as in the seed.
    Round-off is removed: a coefficient below ``rel_tol`` times the largest of
    its polynomial becomes exactly 0, and leading zeros are dropped.

    References
    ----------
    C.-T. Chen, *Linear System Theory and Design*, 4th ed., 2013, §4.3.
    """
    A = square("A", A)
    B = columns("B", B, A.shape[0])
    if B.shape[1] != 1:
        raise DimensionError("B", B, f"one column (a single input), got shape {B.shape}")
    C = rows("C", C, A.shape[0])
    D = shaped("D", D, (C.shape[0], 1))
    if len(output_names) != C.shape[0]:
        raise DimensionError("output_names", output_names, f"{C.shape[0]} names, one per row of C")
    rel_tol = finite_float("rel_tol", rel_tol, 0.0, 1.0)
    G = ct.ss2tf(ct.ss(A, B, C, D))
    result = []
    for i, name in enumerate(output_names):
        den = np.asarray(G.den_array[i][0], dtype=np.float64)
        num = np.asarray(G.num_array[i][0], dtype=np.float64) / den[0]
        num, den = _polynomials.clean(num, rel_tol), _polynomials.clean(den / den[0], rel_tol)
        result.append(TransferFunction(readonly(num), readonly(den), name, input_name))
    return tuple(result)


@dataclass(frozen=True)
class Analysis:
    """Everything the seed's system-analysis experiment shows, for one plant."""

    stability: Stability
    controllability: RankReport
    observability: RankReport
    transfer_functions: tuple[TransferFunction, ...]


def analyze(plant: Plant) -> Analysis:
    """Stability, controllability, observability and transfer functions of ``plant``.

    See :func:`stability`, :func:`controllability`, :func:`observability` and
    :func:`transfer_functions` for the equations.

    References
    ----------
    Seed chapter §4.1.2 and §4.2.2 (system analysis of the flexible link and pendulum).
    """
    return Analysis(
        stability=stability(plant.A),
        controllability=controllability(plant.A, plant.B),
        observability=observability(plant.A, plant.C),
        transfer_functions=transfer_functions(
            plant.A,
            plant.B,
            plant.C,
            plant.D,
            [o.name for o in plant.outputs],
            plant.inputs[0].name,
        ),
    )
