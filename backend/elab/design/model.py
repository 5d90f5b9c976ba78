"""A given LTI model — an identified one, not a plant's physics — as design takes it:
continuous or discrete, one input, any number of outputs, and its continuous equivalent.

Plants have :func:`elab.design.plant_loop.closed_loop`; a model here has states nobody
measures, so :mod:`elab.design.observed` puts an observer in front of its state feedback
and :mod:`elab.design.loop` closes and analyses the loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from elab.design._checks import Matrix, columns, readonly, rows, shaped, square
from elab.errors import DimensionError, InvalidInput
from elab.lti import StateSpaceShape
from elab.validate import finite_float

if TYPE_CHECKING:
    import control as ct

Domain = Literal["continuous", "discrete"]
MAX_STATES = 20  # a model's order: the controller files' limit, and beyond it designs are
# ill-conditioned
MAX_OUTPUTS = 8
MIN_TS = 1e-6  # s: a discrete model's shortest sample time


@dataclass(frozen=True)
class Model(StateSpaceShape):
    """A single-input LTI model in SI units:

    .. math:: x' = A x + B u, \\qquad y = C x + D u

    with :math:`x' = \\dot x` when ``Ts`` is None (continuous) and :math:`x' = x_{k+1}`
    at sample time ``Ts`` seconds otherwise. ``ref`` is the output that follows the
    reference r. The matrices are checked on construction (finite, consistent shapes).
    """

    A: Matrix
    B: Matrix
    C: Matrix
    D: Matrix
    Ts: float | None = None
    ref: int = 0

    def __post_init__(self) -> None:
        A = square("A", self.A)
        n = A.shape[0]
        if n > MAX_STATES:
            raise DimensionError("A", f"{n} states", f"at most {MAX_STATES} states")
        B = columns("B", self.B, n)
        if B.shape[1] != 1:
            raise DimensionError("B", f"{B.shape[1]} columns", "one column: one input u")
        C = rows("C", self.C, n)
        if not 1 <= C.shape[0] <= MAX_OUTPUTS:
            raise DimensionError("C", f"{C.shape[0]} rows", f"1 to {MAX_OUTPUTS} rows (outputs)")
        D = shaped("D", self.D, (C.shape[0], 1))
        if self.Ts is not None:
            finite_float("Ts", self.Ts, MIN_TS, 3600.0)
        if isinstance(self.ref, bool) or not 0 <= self.ref < C.shape[0]:
            raise InvalidInput("ref", self.ref, f"an output index 0 … {C.shape[0] - 1}")
        for name, value in (("A", A), ("B", B), ("C", C), ("D", D)):
            object.__setattr__(self, name, readonly(value))

    @classmethod
    def checked(
        cls, A: Any, B: Any, C: Any, D: Any, Ts: float | None = None, ref: int = 0
    ) -> Model:
        """A model from array-likes (lists, as JSON gives them), checked on construction."""
        return cls(A, B, C, D, Ts, ref)

    @property
    def domain(self) -> Domain:
        return "continuous" if self.Ts is None else "discrete"

    def ss(self) -> ct.StateSpace:
        """The model as python-control state space (``dt`` = Ts, or 0: continuous)."""
        import control as ct  # here: a model is checked and stored without python-control

        return ct.ss(self.A, self.B, self.C, self.D, 0 if self.Ts is None else self.Ts)

    def stable_region(self, p: complex) -> float:
        """How far ``p`` lies inside the stable region: −Re p (continuous) or 1 − |p|."""
        return -p.real if self.Ts is None else 1.0 - abs(p)


def continuous(m: Model) -> Model:
    """The continuous model whose zero-order-hold sampling at ``m.Ts`` is ``m``
    (the inverse of python-control's ``c2d(…, "zoh")``; C and D carry over):

    .. math:: \\begin{bmatrix} A_d & B_d \\\\ 0 & 1 \\end{bmatrix}
              = \\exp\\left(T_s \\begin{bmatrix} A & B \\\\ 0 & 0 \\end{bmatrix}\\right)

    Raises
    ------
    InvalidInput
        ``domain``: a pole at z = 0 or on the negative real axis has no real logarithm,
        so no continuous model samples to it.

    References
    ----------
    G. F. Franklin, J. D. Powell and M. Workman, *Digital Control of Dynamic Systems*,
    3rd ed., 1998, §4.3.3.
    """
    if m.Ts is None:
        return m
    z = np.linalg.eigvals(m.A)
    bad = z[(np.abs(z) < 1e-9) | ((np.abs(z.imag) < 1e-12) & (z.real < 0))]
    if bad.size:
        raise InvalidInput(
            "domain",
            "continuous",
            f"a model whose poles all have a real logarithm; this one has a pole at "
            f"z = {bad[0].real:.4g}, which no continuous model samples to: design it in "
            "discrete time",
        )
    n = m.nx
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = m.A, m.B
    M[n, n] = 1.0
    import scipy.linalg  # here: 0.2 s of imports the web process does without at start-up

    log = scipy.linalg.logm(M) / m.Ts
    if np.max(np.abs(np.imag(log))) > 1e-8 * max(1.0, float(np.max(np.abs(log)))):
        raise InvalidInput(
            "domain", "continuous", "a model with a real continuous equivalent: design it in z"
        )
    log = np.real(log)
    return Model(log[:n, :n], log[:n, n:], m.C, m.D, None, m.ref)


def in_domain(m: Model, domain: Domain) -> Model:
    """``m`` as a continuous model (inverse ZOH) or as it is; a continuous model cannot be
    designed in discrete time without a sample time."""
    if domain == "continuous":
        return continuous(m)
    if m.Ts is None:
        raise InvalidInput("domain", domain, "continuous: this model has no sample time")
    return m
