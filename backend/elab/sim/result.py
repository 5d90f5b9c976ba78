"""Immutable recorded samples of a run (a chunk or the whole run)."""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np
from numpy.typing import NDArray

from elab.plants.base import Channel, Plant

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Samples:
    """Samples ``k0 .. k0+n-1`` of a run, in SI units, absolute coordinates.

    ``r`` reference (with any excitation added there), ``u`` applied input,
    ``y`` measured outputs ``(n, ny)``, ``x`` true states ``(n, nx)``.
    """

    plant: Plant
    Ts: float
    k0: int
    r: Array
    u: Array
    y: Array
    x: Array

    def __post_init__(self) -> None:
        for a in (self.r, self.u, self.y, self.x):
            a.setflags(write=False)

    @property
    def n(self) -> int:
        return int(self.r.size)

    @property
    def t(self) -> Array:
        """Sample times (s)."""
        return np.asarray((self.k0 + np.arange(self.n)) * self.Ts, dtype=np.float64)

    def channels(self) -> list[tuple[Channel, Array]]:
        """Every recorded channel with its unit, in a fixed order."""
        p = self.plant
        ref = p.outputs[p.reference_output]
        chans = [
            (Channel("t", "s", "time"), self.t),
            (Channel("r", ref.unit, f"reference for {ref.label}"), self.r),
            (Channel("u", p.inputs[0].unit, p.inputs[0].label), self.u),
        ]
        chans += [(c, self.y[:, i]) for i, c in enumerate(p.outputs)]
        chans += [
            (Channel(f"x_{c.name}", c.unit, f"state {c.label}"), self.x[:, i])
            for i, c in enumerate(p.states)
        ]
        return chans

    def head(self, n: int) -> Samples:
        """The first ``n`` samples."""
        return Samples(self.plant, self.Ts, self.k0, self.r[:n], self.u[:n], self.y[:n], self.x[:n])

    @staticmethod
    def concatenate(parts: list[Samples]) -> Samples:
        """Join consecutive chunks into one recording."""
        first = parts[0]
        for a, b in pairwise(parts):
            if b.k0 != a.k0 + a.n:
                raise ValueError(f"chunks are not consecutive: {a.k0}+{a.n} then {b.k0}")
        return Samples(
            first.plant,
            first.Ts,
            first.k0,
            *(np.concatenate([getattr(p, f) for p in parts]) for f in "ruyx"),
        )
