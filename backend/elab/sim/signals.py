"""Reference and excitation signals as pure functions of the sample index.

Every signal answers ``sample(k0, n, Ts)``: its values at ``t = (k0 + i) Ts`` for
``i < n``. Because a value depends only on its absolute index, a run stepped in
chunks sees exactly the samples of a run stepped at once. Amplitudes are in the
unit of the channel the signal drives (rad, m or V).
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.validate import finite_array, finite_float

Array = NDArray[np.float64]

PRBS_ORDERS = range(3, 21)  # LFSR register lengths with known maximal taps (scipy)
PRBS_MIN_BAND = 1e-6  # a level held at most 10⁶ samples (17 min at 1 kHz)


def _times(k0: int, n: int, Ts: float) -> Array:
    return (k0 + np.arange(n, dtype=np.float64)) * Ts


@dataclass(frozen=True)
class Step:
    """:math:`r(t) = o + a\\,[t \\ge t_0]`."""

    amplitude: float
    t0: float = 0.0
    offset: float = 0.0

    def sample(self, k0: int, n: int, Ts: float) -> Array:
        t = _times(k0, n, Ts)
        return np.where(t >= self.t0 - 1e-12, self.offset + self.amplitude, self.offset)


@dataclass(frozen=True)
class Square:
    """Square wave between :math:`o + a` and :math:`o - a`, starting high.

    ``duty`` is the fraction of each ``period`` (s) spent high.
    """

    amplitude: float
    period: float
    offset: float = 0.0
    duty: float = 0.5

    def __post_init__(self) -> None:
        finite_float("signal.period", self.period, 0.0, lo_open=True)
        finite_float("signal.duty", self.duty, 0.0, 1.0, lo_open=True)

    def sample(self, k0: int, n: int, Ts: float) -> Array:
        # phase from integer sample counts, so no drift accumulates over long runs (the
        # counts as floats are exact below 2⁵³; computed in place: no temporaries)
        per = self.period / Ts
        phase = np.arange(k0, k0 + n, dtype=np.float64)
        np.mod(phase, per, out=phase)
        phase /= per
        high, low = self.offset + self.amplitude, self.offset - self.amplitude
        return np.where(phase < self.duty, high, low)


@dataclass(frozen=True)
class Sine:
    """:math:`r(t) = o + a \\sin(2\\pi f t + \\varphi)`, ``frequency`` in Hz."""

    amplitude: float
    frequency: float
    phase: float = 0.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        finite_float("signal.frequency", self.frequency, 0.0, lo_open=True)

    def sample(self, k0: int, n: int, Ts: float) -> Array:
        t = _times(k0, n, Ts)
        return self.offset + self.amplitude * np.sin(2 * np.pi * self.frequency * t + self.phase)


@dataclass(frozen=True)
class Chirp:
    """Sine sweep from ``f0`` to ``f1`` Hz over ``sweep`` s, then repeating.

    Linear: :math:`\\varphi(t) = 2\\pi (f_0 t + (f_1 - f_0) t^2 / (2T))`.
    """

    amplitude: float
    f0: float
    f1: float
    sweep: float
    offset: float = 0.0

    def __post_init__(self) -> None:
        finite_float("signal.f0", self.f0, 0.0)
        finite_float("signal.f1", self.f1, 0.0, lo_open=True)
        finite_float("signal.sweep", self.sweep, 0.0, lo_open=True)

    def sample(self, k0: int, n: int, Ts: float) -> Array:
        t = np.mod(_times(k0, n, Ts), self.sweep)
        phi = 2 * np.pi * (self.f0 * t + (self.f1 - self.f0) * t**2 / (2 * self.sweep))
        return self.offset + self.amplitude * np.sin(phi)


@dataclass(frozen=True)
class PRBS:
    """Maximum-length pseudo-random binary sequence, like MATLAB's ``idinput``.

    The register of length ``order`` gives a period of :math:`2^{order} - 1`
    clock intervals; ``band`` is the upper band edge as a fraction of the
    Nyquist frequency (``idinput``'s ``[0 B]``), so each level is held for
    ``round(1/band)`` samples. Levels are ``offset ± amplitude``.
    """

    amplitude: float
    order: int = 10
    band: float = 1.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        if self.order not in PRBS_ORDERS:
            raise InvalidInput("signal.order", self.order, "an integer register length 3..20")
        finite_float("signal.band", self.band, PRBS_MIN_BAND, 1.0)

    @property
    def hold(self) -> int:
        """Samples per clock interval."""
        return max(1, round(1.0 / self.band))

    def sample(self, k0: int, n: int, Ts: float) -> Array:
        bits = _mls(self.order)
        idx = ((k0 + np.arange(n)) // self.hold) % bits.size
        levels = self.offset + self.amplitude * (2.0 * bits[idx] - 1.0)
        return np.asarray(levels, dtype=np.float64)


@lru_cache(maxsize=32)
def _mls(order: int) -> NDArray[np.int8]:
    from scipy.signal import max_len_seq  # a second of imports: only when used

    bits: NDArray[np.int8] = np.asarray(max_len_seq(order)[0], dtype=np.int8)
    bits.setflags(write=False)
    return bits


@dataclass(frozen=True)
class Samples:
    """User-given samples at the run's sample time; the last value holds."""

    values: tuple[float, ...]

    def __post_init__(self) -> None:
        finite_array("signal.values", self.values, (None,))

    def sample(self, k0: int, n: int, Ts: float) -> Array:
        v = np.asarray(self.values, dtype=np.float64)
        return np.asarray(v[np.minimum(k0 + np.arange(n), v.size - 1)], dtype=np.float64)


Signal = Step | Square | Sine | Chirp | PRBS | Samples
SIGNAL_KINDS: dict[str, type[Signal]] = {
    "step": Step,
    "square": Square,
    "sine": Sine,
    "chirp": Chirp,
    "prbs": PRBS,
    "samples": Samples,
}


def signal_kind(signal: Signal) -> str:
    """The signal's name in requests (its key in :data:`SIGNAL_KINDS`)."""
    return next(name for name, cls in SIGNAL_KINDS.items() if type(signal) is cls)


def make_signal(kind: str, **params: float | int | tuple[float, ...]) -> Signal:
    """A signal from its kind name and parameters; errors name the bad field."""
    try:
        cls = SIGNAL_KINDS[kind]
    except KeyError:
        raise InvalidInput("signal.kind", kind, ", ".join(SIGNAL_KINDS)) from None
    for name, value in params.items():
        if name not in cls.__dataclass_fields__:
            raise InvalidInput(
                f"signal.{name}",
                value,
                f"parameters of {kind}: " + ", ".join(cls.__dataclass_fields__),
            )
        if name not in ("values", "order"):
            finite_float(f"signal.{name}", value)
    for name, f in cls.__dataclass_fields__.items():
        if name not in params and f.default is MISSING and f.default_factory is MISSING:
            raise InvalidInput(
                f"signal.{name}",
                None,
                f"a value: {kind} needs "
                + ", ".join(n for n, g in cls.__dataclass_fields__.items() if g.default is MISSING),
            )
    return cls(**params)  # type: ignore[arg-type]
