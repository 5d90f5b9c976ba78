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
    "Ad": lambda R, X, Y, C, W, L: (R, X, X),
    "Bd": lambda R, X, Y, C, W, L: (R, X),
    "C": lambda R, X, Y, C, W, L: (R, Y, X),
    "Ac": lambda R, X, Y, C, W, L: (R, C, C),
    "Bc": lambda R, X, Y, C, W, L: (R, C, W),
    "Cc": lambda R, X, Y, C, W, L: (R, C),
    "Dc": lambda R, X, Y, C, W, L: (R, W),
    "Lw": lambda R, X, Y, C, W, L: (R, C),
    "u_lim": lambda R, X, Y, C, W, L: (R,),
    "quantum": lambda R, X, Y, C, W, L: (R, Y),
    "x": lambda R, X, Y, C, W, L: (R, X),
    "xc": lambda R, X, Y, C, W, L: (R, C),
    "exo": lambda R, X, Y, C, W, L: (R, L, 2 + Y),
    "y_op": lambda R, X, Y, C, W, L: (R, Y),
    "x_op": lambda R, X, Y, C, W, L: (R, X),
}


class SignalFault(Exception):
    """The signals of the run in ``slot`` could not be computed (``__cause__`` says why);
    nothing was advanced, so the others may be stepped again without it."""

    def __init__(self, slot: int, k: int) -> None:
        super().__init__(f"the run's signals could not be computed from sample {k} on")
        self.slot = slot
        self.k = k


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
        self._last_n = 0

    def __len__(self) -> int:
        return len(self._runs)

    def add(self, run: CompiledRun) -> int:
        """Place ``run`` in a free slot (growing the arrays if needed)."""
        slot = next((s for s in range(self._dims[0]) if s not in self._runs), self._dims[0])
        p, c = run.spec.plant, run.controller
        R, X, Y, C, _, L = self._dims
        self._resize(
            max(R, slot + 1 if slot < R else 2 * R), max(X, p.nx), max(Y, p.ny), max(C, c.nc), L
        )
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

    def advance(self, n: int, slots: list[int] | None = None) -> Array:
        """Step the runs in ``slots`` (default: all) by ``n`` samples each.

        Raises :class:`SignalFault` (before advancing any run) if a run's signals cannot
        be computed. Returns the stacked output block ``(slots, n, 2 + NY + NX)`` (a view, valid
        until the next call); :meth:`columns` says where a run's channels are and
        :meth:`samples` copies one run's chunk out as :class:`Samples`.
        """
        if n > self.block:
            raise ValueError(f"n: got {n}; allowed: at most block = {self.block} samples")
        active = np.asarray(sorted(self._runs) if slots is None else slots, dtype=np.int64)
        for s in active[self._exo_off[active] + n > self.block]:
            # a refill starts at the run's next sample: nothing in its block is kept, so
            # the signals are written straight into it
            run = self._runs[int(s)]
            try:
                into = self._a["exo"][s, :, : 2 + run.spec.plant.ny]
                run.exogenous(int(self._k[s]), self.block, out=into)
            except Exception as exc:  # one run's signals must not stop the others
                self._exo_off[s] = self.block  # half written: filled again before use
                raise SignalFault(int(s), int(self._k[s])) from exc
            self._exo_off[s] = 0
        R, X, Y = self._dims[:3]
        width = 2 + Y + X  # grows when a run with more outputs or states joins
        if self._out.shape[1] < n or self._out.shape[0] < R or self._out.shape[2] != width:
            self._out = np.zeros((R, max(n, self._out.shape[1]), width))
        a = self._a
        advance(
            active,
            n,
            a["Ad"],
            a["Bd"],
            a["C"],
            a["Ac"],
            a["Bc"],
            a["Cc"],
            a["Dc"],
            a["Lw"],
            self._use_state,
            a["u_lim"],
            a["quantum"],
            a["x"],
            a["xc"],
            a["exo"],
            self._exo_off,
            a["y_op"],
            a["x_op"],
            self._out,
        )
        self._k[active] += n
        self._last_n = n
        return self._out[:, :n]

    def columns(self, slot: int) -> tuple[slice, slice]:
        """Column slices of outputs ``y`` and states ``x`` of ``slot`` in the block
        (``r`` is column 0, ``u`` column 1)."""
        p, Y = self._runs[slot].spec.plant, self._dims[2]
        return slice(2, 2 + p.ny), slice(2 + Y, 2 + Y + p.nx)

    def samples(self, slot: int, copy: bool = True) -> Samples:
        """A copy of the chunk the last :meth:`advance` produced for ``slot``, or with
        ``copy=False`` views of the block, for a batch that steps no more (its block is
        written again by the next :meth:`advance`)."""
        run, n = self._runs[slot], self._last_n
        ys, xs = self.columns(slot)
        o = self._out[slot, :n]
        columns = (o[:, 0], o[:, 1], o[:, ys], o[:, xs])
        return Samples(
            run.spec.plant,
            run.Ts,
            int(self._k[slot]) - n,
            *(c.copy() if copy else c for c in columns),
        )

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
        a["x_op"][s, :nx], a["y_op"][s, :ny] = p.operating_point, p.C @ p.operating_point
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
            if name != "exo":  # the signals are generated again (below), not copied
                new[tuple(slice(0, d) for d in old.shape)] = old
            self._a[name] = new
        # the layout [r, z...] keeps its column positions, so old values copied into
        # the top-left corner stay where the loop reads them
        self._use_state = _grow(self._use_state, R)
        self._exo_off = np.full(R, L, dtype=np.int64)  # every run's signals refilled
        self._k = _grow(self._k, R)
        self._dims = dims


_T = TypeVar("_T", bound=np.generic)


def _grow(a: NDArray[_T], R: int) -> NDArray[_T]:
    new: NDArray[_T] = np.zeros(R, dtype=a.dtype)
    new[: a.size] = a
    return new
