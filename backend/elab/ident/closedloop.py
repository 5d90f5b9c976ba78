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
    if np.allclose(refs, refs[0]):
        raise InvalidInput("r", "a constant", "a reference that varies (it excites the loop)")
    # the regressors: every reference at lags 0 … taps − 1, zeros before the record
    N, nr = refs.shape
    phi = np.zeros((N, nr * taps))
    for lag in range(taps):
        phi[lag:, lag * nr : (lag + 1) * nr] = refs[: N - lag]
    theta, *_ = np.linalg.lstsq(phi, data.u, rcond=None)
    return replace(data, u=phi @ theta)
