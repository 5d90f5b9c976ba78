"""Identification data sets: input/output samples with a sample time, names and units.

Conventions follow MATLAB's ``iddata`` (Ljung 1999, ch. 14): ``y`` is ``(N, ny)``,
``u`` is ``(N, nu)``, sample ``t`` is at ``t·Ts``; :meth:`IdData.detrend` removes the
mean by default (MATLAB's ``detrend(iddata)``), or a straight line.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from elab.errors import InvalidInput

Array = NDArray[np.float64]
MAX_SAMPLES = 2_000_000
MAX_DECIMATE = 100  # the largest resampling factor
MIN_DECIMATED = 20  # samples a resampled record must keep


def _columns(name: str, values: ArrayLike) -> Array:
    try:
        a = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInput(name, values, "an array of numbers") from None
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[1] == 0:
        raise InvalidInput(name, f"shape {a.shape}", "N samples × channels (N ≥ 2)")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        i, j = bad[0]
        raise InvalidInput(f"{name}[{i}, {j}]", float(a[i, j]), "finite numbers (no NaN or inf)")
    return a


#: sample times a data set may have (s): from 1 GHz sampling to one sample in 30 years; the
#: time axis and every frequency stay well inside double precision (a sample time of 5e-324
#: or 1e308 overflowed them)
TS_RANGE = (1e-9, 1e9)
#: the largest magnitude a channel may reach, and the least its largest may be (a channel
#: of zeros is allowed here and refused where it cannot be used): every method squares
#: the signals and sums them over the samples and lags, and the spectra square those, so
#: a sample of 1e100 overflowed and one of 1e-300 vanished (an input of 1e-300 was
#: "not persistently exciting"); inside this range the results scale with the data
MAGNITUDE = (1e-50, 1e50)


@dataclass(frozen=True)
class IdData:
    """``N`` samples of outputs ``y`` ``(N, ny)`` and inputs ``u`` ``(N, nu)`` at ``Ts``."""

    y: Array
    u: Array
    Ts: float
    output_names: tuple[str, ...] = ()
    input_names: tuple[str, ...] = ()
    output_units: tuple[str, ...] = ()
    input_units: tuple[str, ...] = ()
    #: index of the first sample in the experiment the data came from
    k0: int = 0
    trend: Literal["none", "mean", "linear"] = field(default="none")
    #: samples the source did not have (a rig's dropped samples), filled by linear
    #: interpolation before they got here (:func:`fill_gaps`); said in the notes
    filled: int = 0

    def __post_init__(self) -> None:
        y, u = _columns("y", self.y), _columns("u", self.u)
        if y.shape[0] != u.shape[0]:
            raise InvalidInput("u", f"{u.shape[0]} samples", f"as many samples as y ({y.shape[0]})")
        if y.shape[0] < 2:
            raise InvalidInput("y", f"{y.shape[0]} samples", "at least 2 samples")
        if y.shape[0] > MAX_SAMPLES:
            raise InvalidInput("y", f"{y.shape[0]} samples", f"at most {MAX_SAMPLES:,} samples")
        Ts = self.Ts
        if not isinstance(Ts, int | float) or not TS_RANGE[0] <= Ts <= TS_RANGE[1]:
            raise InvalidInput("Ts", Ts, f"a sample time in [{TS_RANGE[0]:g}, {TS_RANGE[1]:g}] s")
        y.flags.writeable = False
        u.flags.writeable = False
        object.__setattr__(self, "y", y)
        object.__setattr__(self, "u", u)
        object.__setattr__(self, "Ts", float(Ts))
        for attr, n, stem in (
            ("output_names", y.shape[1], "y"),
            ("input_names", u.shape[1], "u"),
            ("output_units", y.shape[1], ""),
            ("input_units", u.shape[1], ""),
        ):
            given = tuple(getattr(self, attr))
            if not given:
                given = tuple(f"{stem}{i + 1}" if stem else "" for i in range(n))
            if len(given) != n:
                raise InvalidInput(attr, list(given), f"{n} entries (one per channel)")
            object.__setattr__(self, attr, given)
        for x, names in ((y, self.output_names), (u, self.input_names)):
            _require_magnitude(x, names)

    @property
    def N(self) -> int:
        return int(self.y.shape[0])

    @property
    def ny(self) -> int:
        return int(self.y.shape[1])

    @property
    def nu(self) -> int:
        return int(self.u.shape[1])

    @property
    def t(self) -> Array:
        return (self.k0 + np.arange(self.N, dtype=np.float64)) * self.Ts

    def __getitem__(self, index: slice) -> IdData:
        """Samples ``index`` (a slice), e.g. ``data[:500]``."""
        if not isinstance(index, slice):
            raise InvalidInput("index", index, "a slice of samples")
        start, _, step = index.indices(self.N)
        if step != 1:
            raise InvalidInput("index", index, "a contiguous slice (step 1)")
        return replace(self, y=self.y[index], u=self.u[index], k0=self.k0 + start)

    def detrend(self, kind: Literal["mean", "linear"] = "mean") -> IdData:
        """Remove each channel's mean (default, as MATLAB) or its least-squares line."""
        if kind not in ("mean", "linear"):
            raise InvalidInput("detrend", kind, "'mean' or 'linear'")
        return replace(self, y=_detrend(self.y, kind), u=_detrend(self.u, kind), trend=kind)

    def decimate(self, q: int) -> IdData:
        """Every ``q``-th sample after an anti-aliasing low-pass (an FIR of 20q + 1 taps,
        applied without phase shift: scipy's ``decimate`` with ``zero_phase``), at
        ``q·Ts`` (MATLAB's ``idresamp``). A record sampled much faster than its dynamics
        (the flexible link at 1 kHz, its resonance at 3 Hz) leaves ARX and subspace fits
        weighting hundreds of hertz of sensor noise, and a subspace horizon of a few
        milliseconds; every tenth sample keeps the dynamics and drops the noise."""
        if not isinstance(q, int) or isinstance(q, bool) or not 1 <= q <= MAX_DECIMATE:
            raise InvalidInput("decimate", q, f"an integer in 1 … {MAX_DECIMATE}")
        if q == 1:
            return self
        if self.N // q < MIN_DECIMATED:
            raise InvalidInput(
                "decimate",
                q,
                f"at most {max(self.N // MIN_DECIMATED, 1)}: {self.N} samples leave fewer "
                f"than {MIN_DECIMATED} after it",
            )
        return replace(
            self, y=decimated(self.y, q), u=decimated(self.u, q), Ts=self.Ts * q, k0=self.k0 // q
        )

    def split(self, at: int | float = 0.5) -> tuple[IdData, IdData]:
        """Estimation and validation parts: the first ``at`` samples (an int) or the first
        fraction ``at`` (a float in (0, 1)), and the rest."""
        n = at if isinstance(at, int) and not isinstance(at, bool) else None
        if n is None:
            if not isinstance(at, float) or not 0 < at < 1:
                raise InvalidInput("split", at, "a sample count or a fraction in (0, 1)")
            n = round(at * self.N)
        if not 2 <= n <= self.N - 2:
            raise InvalidInput("split", at, f"leaving at least 2 samples on each side of {self.N}")
        return self[:n], self[n:]


def decimated(a: Array, q: int) -> Array:
    """Every ``q``-th row of ``a`` after :meth:`IdData.decimate`'s anti-aliasing filter
    (for columns that go with a record: its references)."""
    from scipy.signal import decimate  # scipy.signal: only when asked (0.9 s of imports)

    return np.asarray(
        decimate(a, q, n=20 * q, ftype="fir", axis=0, zero_phase=True), dtype=np.float64
    )


def iddata(y: ArrayLike, u: ArrayLike, Ts: float, **names: tuple[str, ...]) -> IdData:
    """An :class:`IdData` from arrays (1-D for one channel)."""
    return IdData(y, u, Ts, **names)  # type: ignore[arg-type]  # IdData converts and checks


def _detrend(a: Array, kind: str) -> Array:
    """``a`` less each column's mean or line; a constant column becomes exactly zero (its
    mean is rounded: 2.5e45 less its mean left a residue of 1e29 that looked like a signal)."""
    if kind == "mean":
        out = a - a.mean(axis=0)
    else:
        t = np.arange(a.shape[0], dtype=float)
        T = np.column_stack([np.ones_like(t), t])
        coef, *_ = np.linalg.lstsq(T, a, rcond=None)
        out = a - T @ coef
    out[:, np.all(a == a[:1], axis=0)] = 0.0
    return np.asarray(out, dtype=np.float64)


def require_varying(y: Array, names: tuple[str, ...] | list[str], part: str) -> None:
    """Raise unless every output varies over ``part`` of the data: a constant output
    (all zero, a sensor that was not connected) has nothing to identify, and every method
    would fail on it in its own way (an empty order range, a singular matrix)."""
    for j in range(y.shape[1]):
        x = y[:, j]
        scale = float(np.max(np.abs(x))) if x.size else 0.0
        if x.size and float(np.ptp(x)) <= 1e-12 * max(scale, 1e-300):
            raise InvalidInput(
                names[j] if j < len(names) else f"y[{j}]",
                f"an output that is constant ({x[0]:.6g}) over all {x.size} samples of the {part}",
                "an output that responds to the input (is the sensor connected, is this "
                "the right column?)",
            )


def _require_magnitude(x: Array, names: tuple[str, ...]) -> None:
    peaks = np.max(np.abs(x), axis=0)
    for j, peak in enumerate(peaks):
        if peak > MAGNITUDE[1] or 0 < peak < MAGNITUDE[0]:
            raise InvalidInput(
                names[j],
                f"a channel whose largest magnitude is {peak:.3g}",
                f"a largest magnitude in [{MAGNITUDE[0]:g}, {MAGNITUDE[1]:g}], or all zero "
                "(record it in another unit: its squares and sums must stay representable)",
            )


def require_exciting(u: Array, order: int, field: str = "u") -> None:
    """Raise unless every input is persistently exciting of ``order``.

    Checked on the data: the matrix Φ of ``order`` successive lags of the input must have
    full column rank (Ljung 1999, sec. 13.2), judged by the eigenvalues of ΦᵀΦ (λ_min ≤
    1e-13 λ_max, i.e. σ_min ≤ 3e-7 σ_max, counts as rank-deficient). A constant input has
    rank one, so it cannot identify more than a gain; after the mean is removed, rank zero.
    """
    if order <= 0:
        return
    for j in range(u.shape[1]):
        x = u[:, j]
        peak = float(np.max(np.abs(x)))
        x = x / peak if peak > 0 else x  # the judgement is relative: any unit alike
        n = min(order, x.shape[0] - 1)
        # a contiguous copy: BLAS multiplies it several times faster than the strided view
        lags = np.ascontiguousarray(np.lib.stride_tricks.sliding_window_view(x, n))
        s = np.linalg.eigvalsh(lags.T @ lags)[::-1]
        if s[0] <= 0 or s[-1] <= 1e-13 * s[0]:
            constant = bool(np.all(x == x[0]))
            what = "constant" if constant else f"not persistently exciting of order {order}"
            raise InvalidInput(
                f"{field}[{j}]" if u.shape[1] > 1 else field,
                f"an input that is {what}",
                f"an input that excites the system: persistently exciting of "
                f"order ≥ {order} (e.g. PRBS, a chirp or white noise)",
            )


FROZEN = 20  # an output unchanged this many samples (and a twentieth of the data) …
CLIPPED = 0.01  # … or a channel at its extreme for this share of the samples, is said


def suspicious(z: IdData) -> list[str]:
    """What in the record a linear model cannot describe, as notes: an output frozen
    (the same value over a long stretch while the input moves: a stuck sensor, a dead
    zone, a lost connection) and a channel clipped (sitting at its largest or smallest
    value in runs: saturation of an actuator, a sensor's range, a converter's). Signals of
    a few levels (a PRBS, steps) sit at their extremes by design and are not suspected."""
    notes = []
    if z.filled:
        notes.append(
            f"{z.filled} of {z.N} samples were missing from the record (a rig drops a sample "
            "when it falls behind its clock) and were filled by linear interpolation"
        )
    span = max(FROZEN, z.N // 20)
    moving = np.any(np.diff(z.u, axis=0) != 0, axis=1)  # the input changes between t, t+1
    for j, name in enumerate(z.output_names or [f"y{j + 1}" for j in range(z.ny)]):
        start, length = _longest_run(z.y[:, j])
        if length >= span and moving[start : start + length - 1].any():
            notes.append(
                f"{name} stays at {z.y[start, j]:.6g} for {length} samples (t = "
                f"{start * z.Ts:g} … {(start + length - 1) * z.Ts:g} s) while the input "
                "changes: a stuck sensor or a dead zone? A linear model fits it as a plant "
                "that did not respond"
            )
    channels = [(n, z.y[:, j]) for j, n in enumerate(z.output_names or [])]
    channels += [(n, z.u[:, j]) for j, n in enumerate(z.input_names or [])]
    for name, x in channels:
        if np.unique(x).size <= 20:  # a few levels: by design
            continue
        for which, edge in (("largest", x.max()), ("smallest", x.min())):
            at = x == edge
            share = float(at.mean())
            if share >= CLIPPED and _longest_run(at.astype(np.float64), value=1.0)[1] >= 3:
                notes.append(
                    f"{name} sits at its {which} value {edge:.6g} for {100 * share:.1f} % of "
                    "the samples: clipped or saturated? A linear model does not describe "
                    "the plant there"
                )
    return notes


def _longest_run(x: Array, value: float | None = None) -> tuple[int, int]:
    """Start and length of the longest run of equal consecutive values (of ``value`` if
    given)."""
    change = np.flatnonzero(np.diff(x) != 0) + 1
    starts = np.r_[0, change]
    lengths = np.diff(np.r_[starts, x.shape[0]])
    if value is not None:
        keep = x[starts] == value
        if not keep.any():
            return 0, 0
        starts, lengths = starts[keep], lengths[keep]
    k = int(np.argmax(lengths))
    return int(starts[k]), int(lengths[k])


#: samples in one gap that interpolation may fill: 25 ms at 1 kHz, an eighth of the flexible
#: link's fastest period (a rig beside two CPU hogs dropped 13 in a row)
MAX_FILL = 25
MAX_FILL_SHARE = 0.02  # of a record's samples


def fill_gaps(rows: Array, Ts: float, what: str) -> tuple[Array, int]:
    """``rows`` with short runs of NaN rows (samples a rig dropped) filled by linear
    interpolation in each column, and how many rows were filled. A gap longer than
    :data:`MAX_FILL` samples, or gaps over :data:`MAX_FILL_SHARE` of the record, at its
    start or end, are refused naming where (``what``: the record, in words): choose a
    span without them."""
    bad = ~np.all(np.isfinite(rows), axis=1)
    if not bad.any():
        return rows, 0
    edges = np.flatnonzero(np.diff(np.concatenate([[0], bad.astype(np.int8), [0]])))
    starts, stops = edges[::2], edges[1::2]
    worst = int(np.argmax(stops - starts))
    too_long = stops[worst] - starts[worst] > MAX_FILL
    at_edge = bad[0] or bad[-1]
    if too_long or at_edge or bad.mean() > MAX_FILL_SHARE:
        first = int(starts[worst])
        raise InvalidInput(
            "data",
            f"{what}: {int(bad.sum())} samples missing, {int(stops[worst] - starts[worst])} "
            f"in a row from t = {first * Ts:g} s",
            f"at most {MAX_FILL} missing samples in a row, {MAX_FILL_SHARE:.0%} in all and "
            "none at the ends: choose t_from and t_to around them",
        )
    index = np.arange(rows.shape[0])
    filled = rows.copy()
    for j in range(rows.shape[1]):
        filled[bad, j] = np.interp(index[bad], index[~bad], rows[~bad, j])
    return filled, int(bad.sum())
