"""One run, stepped chunk by chunk or all at once, through a private batch."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from elab.laws import ControlLaw
from elab.sim.batch import Batch
from elab.sim.result import Samples
from elab.sim.signals import Signal
from elab.sim.spec import DIVERGENCE_LIMIT, CompiledRun, RunSpec, compile_run


class Simulation:
    """A run in progress. ``advance(n)`` returns the next ``n`` samples.

    Chunks of any size give exactly the samples of :func:`simulate` (same
    loop, exogenous inputs that depend only on the sample index).
    """

    def __init__(self, spec: RunSpec, block: int = 1024) -> None:
        self.compiled = compile_run(spec)
        self._batch = Batch(capacity=1, block=block)
        self._slot = self._batch.add(self.compiled)
        self.diverged_at: int | None = None

    @property
    def k(self) -> int:
        """Index of the next sample."""
        return self._batch.k(self._slot)

    @property
    def remaining(self) -> int:
        if self.diverged_at is not None:
            return 0
        return self.compiled.n_samples - self.k

    def advance(self, n: int) -> Samples:
        """The next ``min(n, remaining)`` samples (an empty chunk at the end)."""
        n = min(n, self.remaining)
        parts = []
        while n > 0:
            step = min(n, self._batch.block)
            self._batch.advance(step)
            parts.append(self._batch.samples(self._slot))
            n -= step
        if not parts:
            return self._empty()
        chunk = parts[0] if len(parts) == 1 else Samples.concatenate(parts)
        bad = divergence_index(chunk)
        if bad is None:
            return chunk
        self.diverged_at = chunk.k0 + bad
        return chunk.head(bad)

    def set_law(self, law: ControlLaw) -> None:
        """Change the controller from the next sample on (same controller state size)."""
        new = compile_run(_replace(self.compiled.spec, law=law))
        if new.controller.nc != self.compiled.controller.nc:
            raise ValueError("controller state size changed: start a new run for a new law")
        self.compiled = new
        self._batch.set_controller(self._slot, new)

    def set_reference(self, reference: Signal) -> None:
        """Change the reference signal from the next sample on."""
        self.compiled = compile_run(_replace(self.compiled.spec, reference=reference))
        self._batch.set_run(self._slot, self.compiled)

    def _empty(self) -> Samples:
        p = self.compiled.spec.plant
        return Samples(
            p,
            self.compiled.Ts,
            self.k,
            np.zeros(0),
            np.zeros(0),
            np.zeros((0, p.ny)),
            np.zeros((0, p.nx)),
        )


def simulate(spec: RunSpec) -> Samples:
    """Run ``spec`` to its end in one call of the stepping loop.

    A run that diverges (see :func:`divergence_index`) is cut at its first
    diverged sample; compare ``result.n`` with the requested length.
    """
    run: CompiledRun = compile_run(spec)
    batch = Batch(capacity=1, block=run.n_samples)
    slot = batch.add(run)
    rows = batch.advance(run.n_samples)[slot]
    samples = batch.samples(slot, copy=False)  # the batch is this call's: no copies
    # u, y and x within the limit, checked row by row in one pass (the columns apart
    # are strided views): no divergence; else the exact first sample of u or x
    bad = None if first_divergence(rows[:, 1:]) is None else divergence_index(samples)
    return samples if bad is None else samples.head(bad)


def first_divergence(rows: NDArray[np.float64]) -> int | None:
    """Index of the first row with a value non-finite or beyond :data:`DIVERGENCE_LIMIT`."""
    if rows.size == 0:
        return None
    # the usual case in two passes without temporaries (a quarter of simulate()'s time
    # was this check): NaN carries through min and max and fails both comparisons
    if rows.min() >= -DIVERGENCE_LIMIT and rows.max() <= DIVERGENCE_LIMIT:
        return None
    with np.errstate(invalid="ignore"):
        ok = (np.abs(rows) <= DIVERGENCE_LIMIT).all(axis=1)
    return None if ok.all() else int(np.argmin(ok))


def diverged(t: float) -> str:
    """Why a run whose loop diverged at ``t`` (s) failed."""
    return f"diverged at t = {t:.4g} s: the closed loop is unstable"


def divergence_index(samples: Samples) -> int | None:
    """Index of the first sample whose input or state diverged."""
    found = [
        i
        for i in (first_divergence(samples.u[:, None]), first_divergence(samples.x))
        if i is not None
    ]
    return min(found) if found else None


def _replace(spec: RunSpec, **changes: object) -> RunSpec:
    from dataclasses import replace

    return replace(spec, **changes)  # type: ignore[arg-type]
