"""Closed-loop data made fit for open-loop methods: the two-stage method (Van den Hof and
Schrama 1993; Ljung 1999, sec. 13.5), and the indirect method's pieces (Ljung 1999,
sec. 13.4): the loop's external input w = u + C y from a known controller C, and the
plant solved from a model of the loop w → y.

In closed loop the input carries the noise the controller fed back (u = S r − S C v),
so a method whose noise model is wrong (ARX, an output-error model on u) is biased. The
reference r is independent of the noise. Stage 1 fits the map r → u, a sensitivity
function, as a long FIR model by least squares and keeps its output û, the part of u the
reference explains. Stage 2 is any open-loop method on û → y (an output-error model for
the plant alone): û is free of the noise, and y = G û + (what G makes of u − û) + noise
is an open-loop record whose disturbance is uncorrelated with its input.

Only the first stage is here: :func:`two_stage` returns the data stage 2 reads, and
:func:`stage_one` the prediction itself, fitted on part of a record (the workflow's
estimation part: validation then reads the measured input).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData
from elab.ident.models import LinearModel

Array = NDArray[np.float64]

#: taps of the first stage's FIR model r → u by default: a sensitivity function whose
#: slowest closed-loop pole is at z = 0.7 has decayed to 1e-6 of its start after 40
DEFAULT_TAPS = 40
MAX_TAPS = 1000
#: multiply-adds stage 1's normal equations may take (rows × parameters²): about a minute
#: on one core of the machines the lab runs on (15,000 rows at 1,001 parameters: 1 s)
MAX_WORK = 1e12
BLOCK = 1 << 21  # numbers of the regressor at a time (16 MiB)


class Sampled(Protocol):
    """A signal that gives its samples ``k0 … k0 + n − 1`` at sample time ``Ts``
    (:mod:`elab.sim.signals`)."""

    def sample(self, k0: int, n: int, Ts: float) -> Array: ...


@dataclass(frozen=True)
class References:
    """The signals that drive a closed loop from outside, one column each, on the samples
    of the data they go with (a run's reference and its input excitation). A column that
    is a known signal not recorded (a run's input excitation) may be given as the signal
    (``signals``: column → signal, with the data's first sample ``k0`` and ``Ts``) and
    sampled where the work is done (:meth:`sampled`): a PRBS's generator is scipy's."""

    values: Array  # (N, nr)
    names: tuple[str, ...]
    signals: tuple[tuple[int, Sampled], ...] = ()
    k0: int = 0
    Ts: float = 1.0

    def sampled(self) -> References:
        """These references with every signal's column sampled."""
        if not self.signals:
            return self
        values = self.values.copy()
        for column, signal in self.signals:
            values[:, column] = signal.sample(self.k0, values.shape[0], self.Ts)
        return replace(self, values=values, signals=())


def two_stage(data: IdData, r: ArrayLike, taps: int = DEFAULT_TAPS) -> IdData:
    """``data`` (recorded in closed loop) with each input replaced by its least-squares
    FIR prediction from the reference(s) ``r`` ((N,) or (N, nr), the samples of
    ``data``), lags 0 … ``taps`` − 1 of every reference: the data an open-loop method
    estimates the plant from (stage 2). Nothing before the first sample is known: the
    first ``taps`` − 1 samples are predicted from the references there are (zeros before)."""
    u, _ = stage_one(data.u, r, taps)
    return replace(data, u=u)


def stage_one(
    inputs: Array, r: ArrayLike, taps: int = DEFAULT_TAPS, fit_rows: int | None = None
) -> tuple[Array, Array]:
    """Stage 1: each column of ``inputs`` (N, nu) predicted by a least-squares FIR of
    the references ``r`` ((N,) or (N, nr)) at lags 0 … ``taps`` − 1 and a constant (an
    input's offset is not the references'), fitted on the first ``fit_rows`` samples
    (all by default) and predicted on all; and the share of each input's variance about
    its mean the prediction explains on those rows (1: all of it)."""
    N = inputs.shape[0]
    n_fit = N if fit_rows is None else fit_rows
    refs = np.asarray(r, dtype=np.float64)
    if refs.ndim == 1:
        refs = refs[:, None]
    if refs.ndim != 2 or refs.shape[0] != N:
        raise InvalidInput(
            "r",
            f"shape {refs.shape}",
            f"one row per sample of the data ({N}), a column per reference",
        )
    if not np.all(np.isfinite(refs)):
        raise InvalidInput("r", "a non-finite value", "finite numbers")
    if not 1 <= taps <= MAX_TAPS:
        raise InvalidInput("taps", taps, f"an integer from 1 to {MAX_TAPS}")
    if 2 * (taps * refs.shape[1] + 1) > n_fit:
        raise InvalidInput(
            "taps",
            taps,
            f"at most {max(n_fit // 2 - 1, 0) // refs.shape[1]} taps for {n_fit} samples "
            f"({refs.shape[1]} reference(s)): twice as many samples as parameters",
        )
    work = n_fit * float(taps * refs.shape[1] + 1) ** 2
    if work > MAX_WORK:
        most = max(int((math.sqrt(MAX_WORK / n_fit) - 1) // refs.shape[1]), 0)
        raise InvalidInput(
            "taps",
            taps,
            f"at most {most} taps on {n_fit:,} samples and {refs.shape[1]} reference(s) (the "
            f"first stage's least squares would take {work:.1e} multiply-adds, over "
            f"{MAX_WORK:.0e}); or a shorter stretch of the record",
        )
    if np.all(refs[:n_fit] == refs[0]):
        raise InvalidInput("r", "a constant", "a reference that varies (it excites the loop)")
    # each reference and input scaled to at most 1 in magnitude: the prediction does not
    # change, and 1e308 or subnormal records neither overflow nor underflow the sums
    r_scale, u_scale = _scale(refs), _scale(inputs)
    refs, inputs = refs / r_scale, inputs / u_scale
    # the normal equations of u on every reference at lags 0 … taps − 1 (zeros before the
    # record), a block of rows at a time: the whole regressor of a 2,000,000-sample record
    # at 40 taps would be 640 MB. The last column is the constant.
    nr, nu = refs.shape[1], inputs.shape[1]
    p = nr * taps + 1
    gram, cross = np.zeros((p, p)), np.zeros((p, nu))
    rows = max(1, BLOCK // p)
    for k0 in range(0, n_fit, rows):
        phi = _regressors(refs, taps, k0, min(n_fit, k0 + rows))
        gram += phi.T @ phi
        cross += phi.T @ inputs[k0 : k0 + phi.shape[0]]
    theta = np.linalg.lstsq(gram, cross, rcond=None)[0]
    # the prediction is the FIR filter itself: each reference convolved with its taps
    # (theta is lag-major: row lag·nr + i belongs to reference i), and the constant
    u = np.tile(theta[-1], (N, 1))
    for j in range(nu):
        for i in range(nr):
            u[:, j] += np.convolve(refs[:, i], theta[i:-1:nr, j])[:N]
    fitted, measured = u[:n_fit], inputs[:n_fit]
    spread = np.var(measured, axis=0)
    explained = 1 - np.var(measured - fitted, axis=0) / np.where(spread > 0, spread, 1.0)
    return u * u_scale, np.clip(explained, 0.0, 1.0)


def _scale(columns: Array) -> Array:
    """Each column's largest magnitude (1 for a column of zeros)."""
    top = np.max(np.abs(columns), axis=0)
    return np.where(top > 0, top, 1.0)


def _regressors(refs: Array, taps: int, k0: int, k1: int) -> Array:
    """Rows ``k0 … k1 − 1`` of the regressor matrix: each reference at lags 0 … taps − 1
    (lag-major), zeros before the first sample, then a column of ones."""
    nr = refs.shape[1]
    phi = np.zeros((k1 - k0, nr * taps + 1))
    phi[:, -1] = 1.0
    for lag in range(taps):
        lo = max(k0, lag)  # the first row whose lagged sample exists
        if lo < k1:
            phi[lo - k0 :, lag * nr : (lag + 1) * nr] = refs[lo - lag : k1 - lag]
    return phi


@dataclass(frozen=True)
class Controller:
    """A known linear controller of a loop recorded at the data's sample time, as the
    indirect method reads it: u = w − C(q) y, with C(q) = num(q⁻¹) / den(q⁻¹) (one input,
    one output) and w the loop's external input (the reference through the controller,
    and any excitation). ``u = r − 0.6 y`` is ``num = (0.6,)``, ``den = (1,)``."""

    num: tuple[float, ...]
    den: tuple[float, ...]

    def __post_init__(self) -> None:
        for name, coefs in (("num", self.num), ("den", self.den)):
            if not 1 <= len(coefs) <= MAX_CONTROLLER or not all(map(np.isfinite, coefs)):
                raise InvalidInput(
                    f"indirect.{name}",
                    list(coefs),
                    f"1 to {MAX_CONTROLLER} finite coefficients of q⁻¹",
                )
        if self.den[0] == 0:
            raise InvalidInput("indirect.den", list(self.den), "a first coefficient other than 0")

    def external(self, u: Array, y: Array) -> Array:
        """w = u + C(q) y for one input and one output ((N, 1) each), the controller at
        rest before the first sample."""
        from scipy.signal import lfilter

        with np.errstate(all="ignore"):  # a controller that blows up is refused below
            w = np.asarray(u + lfilter(self.num, self.den, y, axis=0), dtype=np.float64)
        if not np.all(np.isfinite(w)):
            raise InvalidInput(
                "indirect",
                {"num": list(self.num), "den": list(self.den)},
                "a controller whose output C(q) y stays finite on these data",
            )
        return w

    def state_space(self) -> tuple[Array, Array, Array, Array]:
        """C(q) as a discrete state space (A, B, C, D)."""
        from scipy.signal import tf2ss

        n = max(len(self.num), len(self.den))
        if n == 1:  # a gain: no states
            gain = np.array([[self.num[0] / self.den[0]]])
            return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), gain
        num = np.zeros(n)
        den = np.zeros(n)
        num[: len(self.num)], den[: len(self.den)] = self.num, self.den
        A, B, C, D = (  # coefficients of q⁻¹ padded alike: z's, scaled
            np.atleast_2d(np.asarray(m, dtype=np.float64)) for m in tf2ss(num, den)
        )
        return A, B, C, D


MAX_CONTROLLER = 50  # coefficients of the indirect method's controller polynomials


def plant_from_loop(loop: LinearModel, controller: Controller) -> LinearModel:
    """The plant u → y from a model of the closed loop w → y and the loop's known
    controller (u = w − C y): y = G_cl (u + C y), solved for y. Its states are the loop
    model's and the controller's (their poles cancel only in the limit of an exact
    loop model: nothing is cut). An output-error model of the plant (K = 0): the loop
    model's noise description is the closed loop's, not the plant's."""
    Ak, Bk, Ck, Dk = controller.state_space()
    A, B, C, D = loop.A, loop.B, loop.C, loop.D
    n, nk = A.shape[0], Ak.shape[0]
    feedthrough = np.eye(1) - D @ Dk
    if abs(float(feedthrough[0, 0])) < 1e-12:
        raise InvalidInput(
            "indirect",
            "an algebraic loop",
            "a controller or loop model with a delay (D·C(0) ≠ 1: u = w − C y is unsolvable)",
        )
    M = np.linalg.inv(feedthrough)
    # y = M (C x + D Ck xk + D u); w = u + Ck xk + Dk y
    Cy = np.hstack([M @ C, M @ D @ Ck]) if nk else M @ C
    Dy = M @ D
    Cw = np.hstack([Dk @ M @ C, Ck + Dk @ M @ D @ Ck]) if nk else Dk @ M @ C
    Dw = np.eye(1) + Dk @ M @ D
    top = np.hstack([A, np.zeros((n, nk))]) if nk else A
    Aa = top + B @ Cw
    Ba = B @ Dw
    if nk:
        Aa = np.vstack([Aa, np.hstack([np.zeros((nk, n)), Ak]) + Bk @ Cy])
        Ba = np.vstack([Ba, Bk @ Dy])
    return LinearModel(
        Aa,
        Ba,
        Cy,
        Dy,
        np.zeros((n + nk, 1)),
        loop.Ts,
        loop.noise_variance,
        loop.parameters,
    )
