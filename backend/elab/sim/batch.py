"""Many runs stepped together by one call of the compiled loop.

A :class:`Batch` holds its runs' matrices and states in stacked arrays padded
to the largest dimensions present; a slot is one run. Exogenous inputs
(reference, excitation, noise) are generated in blocks of ``block`` samples per
run, so the Python cost per run is paid once per block, not once per chunk.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from elab.sim.kernel import advance
from elab.sim.result import Samples
from elab.sim.spec import CompiledRun

Array = NDArray[np.float64]

# name -> shape from (R, NX, NY, NC, NW, L)
_MATRICES: dict[str, Callable[..., tuple[int, ...]]] = {
    "Ad": lambda R, X, Y, C, W, L: (R, X, X), "Bd": lambda R, X, Y, C, W, L: (R, X),
    "C": lambda R, X, Y, C, W, L: (R, Y, X), "Ac": lambda R, X, Y, C, W, L: (R, C, C),
    "Bc": lambda R, X, Y, C, W, L: (R, C, W), "Cc": lambda R, X, Y, C, W, L: (R, C),
    "Dc": lambda R, X, Y, C, W, L: (R, W), "Lw": lambda R, X, Y, C, W, L: (R, C),
    "u_lim": lambda R, X, Y, C, W, L: (R,), "quantum": lambda R, X, Y, C, W, L: (R, Y),
    "x": lambda R, X, Y, C, W, L: (R, X), "xc": lambda R, X, Y, C, W, L: (R, C),
    "exo": lambda R, X, Y, C, W, L: (R, L, 2 + Y),
}


class Batch:
    """Stacked runs advanced together; ``add`` returns the run's slot."""

    def __init__(self, capacity: int = 4, block: int = 1024) -> None:
        self.block = block
        self._dims = (capacity, 1, 1, 0, 2, block)
        self._a: dict[str, Array] = {k: np.zeros(f(*self._dims)) for k, f in _MATRICES.items()}
        self._use_state = np.zeros(capacity, dtype=np.bool_)
        self._exo_off = np.zeros(capacity, dtype=np.int64)
        self._k = np.zeros(capacity, dtype=np.int64)
        self._runs: dict[int, CompiledRun] = {}
        self._out = np.zeros((capacity, 0, 0))

    def __len__(self) -> int:
        return len(self._runs)

    def add(self, run: CompiledRun) -> int:
        """Place ``run`` in a free slot (growing the arrays if needed)."""
        slot = next((s for s in range(self._dims[0]) if s not in self._runs), self._dims[0])
        p, c = run.spec.plant, run.controller
        R, X, Y, C, _, L = self._dims
        self._resize(max(R, slot + 1 if slot < R else 2 * R), max(X, p.nx), max(Y, p.ny),
                     max(C, c.nc), L)
        self._runs[slot] = run
        self._load(slot, run)
        self._k[slot] = 0
        self._exo_off[slot] = self.block  # forces a refill before the first step
        return slot

    def remove(self, slot: int) -> None:
        """Free ``slot``; its arrays are zeroed on the next ``add``."""
        del self._runs[slot]

    def k(self, slot: int) -> int:
        """Index of the next sample of the run in ``slot``."""
        return int(self._k[slot])

    def set_controller(self, slot: int, run: CompiledRun) -> None:
        """Swap in a new controller (same state size), keeping plant and controller state."""
        xc = self._a["xc"][slot].copy()
        self._runs[slot] = run
        self._load(slot, run, keep_state=True)
        self._a["xc"][slot] = xc

    def refresh_exogenous(self, slot: int) -> None:
        """Regenerate the signals from the next sample on (after a signal change)."""
        self._exo_off[slot] = self.block

    def set_run(self, slot: int, run: CompiledRun) -> None:
        """Replace the spec of ``slot`` (new signals), keeping every state."""
        self._runs[slot] = run
        self.refresh_exogenous(slot)

    def advance(self, n: int, slots: list[int] | None = None) -> dict[int, Samples]:
        """Step the runs in ``slots`` (default: all) by ``n`` samples each."""
        if n > self.block:
            raise ValueError(f"n: got {n}; allowed: at most block = {self.block} samples")
        active = sorted(self._runs) if slots is None else slots
        for s in active:
            if self._exo_off[s] + n > self.block:
                exo = self._runs[s].exogenous(int(self._k[s]), self.block)
                self._a["exo"][s, :, : exo.shape[1]] = exo
                self._exo_off[s] = 0
        R, X, Y = self._dims[:3]
        if self._out.shape[1] < n or self._out.shape[0] < R:
            self._out = np.zeros((R, n, 2 + Y + X))
        a = self._a
        advance(np.asarray(active, dtype=np.int64), n, a["Ad"], a["Bd"], a["C"], a["Ac"],
                a["Bc"], a["Cc"], a["Dc"], a["Lw"], self._use_state, a["u_lim"], a["quantum"],
                a["x"], a["xc"], a["exo"], self._exo_off, self._out)
        result = {s: self._samples(s, n) for s in active}
        self._k[active] += n
        return result

    def _samples(self, s: int, n: int) -> Samples:
        run, Y = self._runs[s], self._dims[2]
        p = run.spec.plant
        o = self._out[s, :n]
        return Samples(p, run.Ts, int(self._k[s]), o[:, 0].copy(), o[:, 1].copy(),
                       o[:, 2:2 + p.ny] + p.C @ p.operating_point,
                       o[:, 2 + Y:2 + Y + p.nx] + p.operating_point)

    def _load(self, s: int, run: CompiledRun, keep_state: bool = False) -> None:
        a, p, c = self._a, run.spec.plant, run.controller
        nx, ny, nc, m = p.nx, p.ny, c.nc, c.Dc.size
        for name in _MATRICES:
            if name != "exo" and not (keep_state and name in ("x", "xc")):
                a[name][s] = 0.0
        a["Ad"][s, :nx, :nx], a["Bd"][s, :nx], a["C"][s, :ny, :nx] = run.Ad, run.Bd, p.C
        a["Ac"][s, :nc, :nc], a["Bc"][s, :nc, :m] = c.Ac, c.Bc
        a["Cc"][s, :nc], a["Dc"][s, :m], a["Lw"][s, :nc] = c.Cc, c.Dc, c.Lw
        a["u_lim"][s], a["quantum"][s, :ny] = run.u_lim, run.quantum
        if not keep_state:
            a["x"][s, :nx] = run.x0
        self._use_state[s] = c.feedback == "state"

    def _resize(self, R: int, X: int, Y: int, C: int, L: int) -> None:
        dims = (R, X, Y, C, 1 + max(X, Y), L)
        if dims == self._dims:
            return
        for name, shape in _MATRICES.items():
            new = np.zeros(shape(*dims))
            old = self._a[name]
            new[tuple(slice(0, d) for d in old.shape)] = old
            self._a[name] = new
        # the layout [r, z...] and [r, e, v...] keeps its column positions, so old
        # values copied into the top-left corner stay where the loop reads them
        self._use_state = _grow(self._use_state, R)
        self._exo_off = _grow(self._exo_off, R)
        self._k = _grow(self._k, R)
        self._dims = dims


_T = TypeVar("_T", bound=np.generic)


def _grow(a: NDArray[_T], R: int) -> NDArray[_T]:
    new: NDArray[_T] = np.zeros(R, dtype=a.dtype)
    new[: a.size] = a
    return new
