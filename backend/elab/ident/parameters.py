"""Each model kind's own parameters: what its estimator found besides the state space
(polynomials and their standard deviations, losses, how the search went). A
:class:`~elab.ident.models.LinearModel` carries one of these as ``parameters``; its kind
is the parameters' type.

Polynomials are coefficient arrays in powers of q⁻¹, a₀ = 1 first; B is given with nk
leading zeros, as MATLAB's ``arx`` (Ljung 1999, sec. 4.2). Losses are the mean squared
one-step prediction error V = (1/n) Σ ε² over the ``samples`` used, and FPE is Akaike's
final prediction error V (1 + d/n) / (1 − d/n) for d parameters (Ljung 1999, sec. 16.4).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
Ints = NDArray[np.int64]


@dataclass(frozen=True)
class ArxParameters:
    """A(q) y(t) = B(q) u(t − nk) + e(t), one output and one input (:func:`~elab.ident.
    polynomial.arx`); ``aic`` = log V + 2d/n."""

    na: int
    nb: int
    nk: int
    A: Array
    B: Array
    dA: Array  # standard deviations of A's coefficients (0 for a₀)
    dB: Array  # of B's (0 for the nk leading zeros)
    loss: float
    fpe: float
    aic: float
    samples: int


@dataclass(frozen=True)
class ArxOrders:
    """``na`` (ny,), ``nb`` and ``nk`` (ny, nu), checked."""

    na: Ints
    nb: Ints
    nk: Ints

    @property
    def n(self) -> Ints:
        """Each output's degree: its first regression sample and its number of states."""
        lag = np.where(self.nb > 0, self.nb + self.nk - 1, 0).max(axis=1)
        return np.asarray(np.maximum(self.na, lag), dtype=np.int64)


@dataclass(frozen=True)
class MimoArxParameters:
    """A_i(q) y_i(t) = Σ_j B_ij(q) u_j(t − nk_ij) + e_i(t), several inputs or outputs, one
    least-squares problem per output (:func:`~elab.ident.multivariable.arx_per_output`).
    Indexed [output] and [output][input]; the statistics are each output's."""

    orders: ArxOrders
    A: tuple[Array, ...]
    B: tuple[tuple[Array, ...], ...]
    dA: tuple[Array, ...]
    dB: tuple[tuple[Array, ...], ...]
    loss: tuple[float, ...]
    fpe: tuple[float, ...]
    aic: tuple[float, ...]  # −∞ for an output fitted exactly
    samples: tuple[int, ...]


@dataclass(frozen=True)
class ArmaxParameters:
    """A(q) y(t) = B(q) u(t − nk) + C(q) e(t) by the prediction-error method
    (:func:`~elab.ident.pem.armax`): the start the descent began from that won, every
    start's final loss, and whether C's roots were held at the stability margin (the
    noise model wants a root on the unit circle: a drift)."""

    na: int
    nb: int
    nc: int
    nk: int
    A: Array
    B: Array
    C: Array
    loss: float
    iterations: int
    start: str
    start_losses: Mapping[str, float]
    c_at_margin: bool
    fpe: float
    samples: int


@dataclass(frozen=True)
class OeParameters:
    """y(t) = B(q)/F(q) u(t − nk) + e(t) by the prediction-error method
    (:func:`~elab.ident.pem.oe`), with the winning start and every start's loss."""

    nb: int
    nf: int
    nk: int
    B: Array
    F: Array
    loss: float
    iterations: int
    start: str
    start_losses: Mapping[str, float]
    fpe: float
    samples: int


@dataclass(frozen=True)
class UnstableChoice:
    """An estimate with a pole outside the unit circle, kept or reflected by which fits
    the estimation data better (simulated from its estimated initial state), in %."""

    fit_as_estimated: float
    fit_reflected: float


@dataclass(frozen=True)
class N4sidParameters:
    """A subspace model (:func:`~elab.ident.subspace.n4sid`) of ``order`` states at
    ``horizon`` block rows: the singular values that chose it, the estimation record's x₀,
    how B and D were had, the poles reflected into the unit circle (|z| before and after
    each), and how K was had: ``"riccati"``, or ``"none"`` when the Riccati equation had no
    stabilising solution (K = 0: the predictor simulates)."""

    order: int
    horizon: int
    singular_values: Array
    x0: Array
    bd: Literal["subspace", "simulation"]
    reflected: tuple[tuple[float, float], ...]
    choice: UnstableChoice | None  # with an unstable estimate under stable="auto"
    kalman: Literal["riccati", "none"]

    @property
    def stabilised(self) -> bool:
        return bool(self.reflected)


@dataclass(frozen=True)
class LinkParameters:
    """A rotary flexible link's physics (:func:`~elab.ident.physical.link`), as the ratios
    its signals determine: ``a`` = K_s/J_eq, ``b`` = K_s/J_l, ``c`` = B_eq/J_eq, ``g`` =
    k_u/J_eq, ``f`` = τ_c/J_eq, ``beta`` = B_l/J_eq, ``beta_l`` = B_l/J_l (1/s² or 1/s,
    V⁻¹ s⁻² for ``g``), the dead zone ``u_dead`` (V) and ``sigma``, the strain gauge's
    true gain over its calibration; ``std`` their standard deviations; the servo equation
    fitted on ``moving_samples`` of ``samples``; ``residual_rms`` of the servo and link
    equations (rad/s²); ``input_delay``, s after its sample that the voltage took effect
    (the best fit's)."""

    a: float
    b: float
    c: float
    g: float
    f: float
    u_dead: float
    beta: float
    beta_l: float
    sigma: float
    std: Mapping[str, float]
    samples: int
    moving_samples: int
    bandwidth: float
    residual_rms: tuple[float, float]
    input_delay: float


ModelParameters = (
    ArxParameters
    | MimoArxParameters
    | ArmaxParameters
    | OeParameters
    | N4sidParameters
    | LinkParameters
)
