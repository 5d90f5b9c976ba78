"""Closed-loop data made fit for open-loop methods: the two-stage method (Van den Hof and
Schrama 1993; Ljung 1999, sec. 13.5).

In closed loop the input carries the noise the controller fed back (u = S r − S C v),
so a method whose noise model is wrong (ARX, an output-error model on u) is biased. The
reference r is independent of the noise. Stage 1 fits the map r → u, a sensitivity
function, as a long FIR model by least squares and keeps its output û, the part of u the
reference explains. Stage 2 is any open-loop method on û → y (an output-error model for
the plant alone): û is free of the noise, and y = G û + (what G makes of u − û) + noise
is an open-loop record whose disturbance is uncorrelated with its input.

Only the first stage is here: :func:`two_stage` returns the data stage 2 reads.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData

Array = NDArray[np.float64]

#: taps of the first stage's FIR model r → u by default: a sensitivity function whose
#: slowest closed-loop pole is at z = 0.7 has decayed to 1e-6 of its start after 40
DEFAULT_TAPS = 40
MAX_TAPS = 1000
BLOCK = 1 << 21  # numbers of the regressor at a time (16 MiB)


def two_stage(data: IdData, r: ArrayLike, taps: int = DEFAULT_TAPS) -> IdData:
    """``data`` (recorded in closed loop) with each input replaced by its least-squares
    FIR prediction from the reference(s) ``r`` ((N,) or (N, nr), the samples of
    ``data``), lags 0 … ``taps`` − 1 of every reference: the data an open-loop method
    estimates the plant from (stage 2). Nothing before the first sample is known: the
    first ``taps`` − 1 samples are predicted from the references there are (zeros before)."""
    refs = np.asarray(r, dtype=np.float64)
    if refs.ndim == 1:
        refs = refs[:, None]
    if refs.ndim != 2 or refs.shape[0] != data.N:
        raise InvalidInput(
            "r",
            f"shape {refs.shape}",
            f"one row per sample of the data ({data.N}), a column per reference",
        )
    if not np.all(np.isfinite(refs)):
        raise InvalidInput("r", "a non-finite value", "finite numbers")
    if not 1 <= taps <= MAX_TAPS:
        raise InvalidInput("taps", taps, f"an integer from 1 to {MAX_TAPS}")
    if 2 * taps * refs.shape[1] > data.N:
        raise InvalidInput(
            "taps",
            taps,
            f"at most {data.N // (2 * refs.shape[1])} taps for {data.N} samples "
            f"({refs.shape[1]} reference(s)): twice as many samples as parameters",
        )
    if np.all(refs == refs[0]):
        raise InvalidInput("r", "a constant", "a reference that varies (it excites the loop)")
    # each reference and input scaled to at most 1 in magnitude: the prediction does not
    # change, and 1e308 or subnormal records neither overflow nor underflow the sums
    r_scale, u_scale = _scale(refs), _scale(data.u)
    refs, inputs = refs / r_scale, data.u / u_scale
    # the normal equations of u on every reference at lags 0 … taps − 1 (zeros before the
    # record), a block of rows at a time: the whole regressor of a 2,000,000-sample record
    # at 40 taps would be 640 MB
    N, nr = refs.shape
    p = nr * taps
    gram, cross = np.zeros((p, p)), np.zeros((p, data.nu))
    rows = max(1, BLOCK // p)
    for k0 in range(0, N, rows):
        phi = _regressors(refs, taps, k0, min(N, k0 + rows))
        gram += phi.T @ phi
        cross += phi.T @ inputs[k0 : k0 + phi.shape[0]]
    theta = np.linalg.lstsq(gram, cross, rcond=None)[0]
    # the prediction is the FIR filter itself: each reference convolved with its taps
    # (theta is lag-major: row lag·nr + i belongs to reference i)
    u = np.zeros_like(data.u)
    for j in range(data.nu):
        for i in range(nr):
            u[:, j] += np.convolve(refs[:, i], theta[i::nr, j])[:N]
    return replace(data, u=u * u_scale)


def _scale(columns: Array) -> Array:
    """Each column's largest magnitude (1 for a column of zeros)."""
    top = np.max(np.abs(columns), axis=0)
    return np.where(top > 0, top, 1.0)


def _regressors(refs: Array, taps: int, k0: int, k1: int) -> Array:
    """Rows ``k0 … k1 − 1`` of the regressor matrix: each reference at lags 0 … taps − 1
    (lag-major), zeros before the first sample."""
    nr = refs.shape[1]
    phi = np.zeros((k1 - k0, nr * taps))
    for lag in range(taps):
        lo = max(k0, lag)  # the first row whose lagged sample exists
        if lo < k1:
            phi[lo - k0 :, lag * nr : (lag + 1) * nr] = refs[lo - lag : k1 - lag]
    return phi
