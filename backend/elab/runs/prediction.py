"""What the model predicts for a run, and how far the run went from it.

A run's prediction is the simulation of the same plant model, control law, reference,
excitation, start state and actuator limit, with ideal sensors (no noise, no
quantisation), the run's live changes of gains and reference applied at the samples they
took effect. For a simulation run without noise the prediction *is* the run (the same
stepping loop); what separates them is the run's sensor noise and quantisation. For a rig
run it is the nominal linear model of the flexible link, so the gap is everything the
model leaves out: the rig's own parameters, friction, the motor's dead zone, the
sensors. A Python controller is stepped in its sandbox as on the server.

:func:`predict` runs in a worker process (it may run a user's code and a long loop);
:func:`compare` reads the recording part by part beside it.
"""

from __future__ import annotations

import asyncio
import math
from collections import OrderedDict
from collections.abc import Awaitable, Callable, Hashable, Sequence
from dataclasses import dataclass, replace
from itertools import pairwise
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from elab.engines.settings import CodeSettings
from elab.laws import ControlLaw, is_code
from elab.sim.signals import Signal
from elab.sim.spec import RunSpec

if TYPE_CHECKING:
    from elab.design.response import StepInfo

Array = NDArray[np.float64]
PART = 65_536  # recorded rows compared at a time


@dataclass(frozen=True)
class Replayed:
    """A live change to replay: from sample ``k`` on, ``law`` and/or ``reference``
    (``None``: kept)."""

    k: int
    law: ControlLaw | None
    reference: Signal | None


@dataclass(frozen=True)
class Predicted:
    """The predicted columns (``u`` then the plant's outputs, SI units, sample ``k`` at
    row ``k``); ``diverged_at``: s where the predicted loop diverged (the columns end
    there); ``replayed``: live changes applied; ``skipped``: live changes it could not
    apply (a Python controller's run replays none), said in ``notes``."""

    names: tuple[str, ...]
    values: Array  # (n, len(names))
    diverged_at: float | None
    replayed: int
    notes: tuple[str, ...]


def predict(
    spec: RunSpec,
    changes: Sequence[Replayed] = (),
    limit: int | None = None,
    code: CodeSettings | None = None,
) -> Predicted:
    """The prediction of the first ``min(limit, its length)`` samples of ``spec``'s run
    with ``changes`` replayed; ``spec``'s sensors are made ideal here."""
    # here, in the worker that predicts: the stepping code brings numba and python-control
    from elab.engines.coded import run_through
    from elab.sim.engine import Simulation
    from elab.sim.spec import compile_run

    ideal = replace(spec, noise_seed=None, quantize=False)
    run = compile_run(ideal)
    n = run.n_samples if limit is None else min(limit, run.n_samples)
    p = spec.plant
    names = ("u", *(c.name for c in p.outputs))
    notes: list[str] = []
    if is_code(spec.law):
        if changes:
            notes.append(
                f"{len(changes)} live change(s) of the reference are not in the prediction: "
                "a Python controller's prediction runs with the reference it started with"
            )
        out = run_through(run, code)
        rows = out.rows[:n]
        values = rows[:, 1 : 2 + p.ny]
        if out.failed is not None and not out.failed.startswith("diverged"):
            notes.append(f"the controller failed in the prediction: {out.failed}")
        ended = rows.shape[0] < n
        return Predicted(
            names,
            np.ascontiguousarray(values),
            rows.shape[0] * run.Ts if ended else None,
            0,
            tuple(notes),
        )
    sim = Simulation(ideal)
    parts = []
    replayed = 0
    for change in sorted(changes, key=lambda c: c.k):
        if change.k >= n:
            break
        parts.append(sim.advance(change.k - sim.k))
        if sim.diverged_at is not None:
            break
        if change.law is not None:
            try:
                sim.set_law(change.law)
            except ValueError:
                notes.append(
                    f"the change at sample {change.k} swapped in a controller of another "
                    "order; the prediction keeps the one before it"
                )
        if change.reference is not None:
            sim.set_reference(change.reference)
        replayed += 1
    if sim.diverged_at is None:
        parts.append(sim.advance(n - sim.k))
    u = np.concatenate([s.u for s in parts]) if parts else np.zeros(0)
    y = np.concatenate([s.y for s in parts]) if parts else np.zeros((0, p.ny))
    values = np.column_stack([u, y]) if u.size else np.zeros((0, len(names)))
    at = None if sim.diverged_at is None else sim.diverged_at * run.Ts
    return Predicted(names, values, at, replayed, tuple(notes))


@dataclass(frozen=True)
class Gap:
    """How far a recorded channel is from its prediction over the samples compared:
    root mean square and largest ``|run − prediction|``, and where the largest is (s)."""

    name: str
    rms: float
    max_abs: float
    t_max: float


#: the fewest samples of constant reference that make a step worth characterising
MIN_STEP_SAMPLES = 20
#: steps characterised at most (a 1-hour square wave has thousands)
MAX_STEPS = 20


@dataclass(frozen=True)
class StepComparison:
    """One step of the reference (constant from ``t`` for ``span`` s), the reference
    output's response in the run and in the prediction: the design page's
    characteristics (:func:`elab.design.step_info`) of each, measured from where its own
    output was at the step (the run's: ``start``) toward ``target`` (both absolute);
    ``None`` where a response has fewer than two measured samples."""

    output: str
    t: float
    span: float
    start: float
    target: float
    run: StepInfo | None
    prediction: StepInfo | None


def step_segments(r: Array, min_samples: int = MIN_STEP_SAMPLES) -> list[tuple[int, int]]:
    """``(k0, k1)`` of each span where the reference ``r`` holds one value for at least
    ``min_samples`` samples (a step, a square wave's half period; a sine has none), the
    first :data:`MAX_STEPS`."""
    if r.size == 0:
        return []
    edges = np.flatnonzero(np.abs(np.diff(r)) > 1e-12 * np.maximum(1.0, np.abs(r[1:]))) + 1
    bounds = [0, *edges.tolist(), r.size]
    spans = [(a, b) for a, b in pairwise(bounds) if b - a >= min_samples]
    return spans[:MAX_STEPS]


def step_response_info(y: Array, Ts: float, start: float, target: float) -> StepInfo | None:
    """The characteristics of one span's samples ``y`` (NaN: not measured, left out) as a
    step from ``start`` to ``target``: :func:`elab.design.step_info` of ``y − start``
    toward ``target − start``, its peak and steady state given back in absolute terms."""
    from elab.design import step_info  # on the thread that compares (python-control)

    k = np.flatnonzero(np.isfinite(y))
    if k.size < 2:
        return None
    info = step_info(k * Ts, y[k] - start, target - start)
    return replace(info, peak=info.peak + start, steady_state=info.steady_state + start)


def compare_steps(
    predicted: Predicted,
    output: str,
    r: Array,
    y: Array,
    offset: float,
    Ts: float,
) -> tuple[StepComparison, ...]:
    """Each step of the recorded reference ``r`` (the reference output ``output``'s,
    ``offset`` its operating point) with the run's response ``y`` and the prediction's,
    over the samples both have."""
    if output not in predicted.names:
        return ()
    j = predicted.names.index(output)
    m = min(r.size, y.size, predicted.values.shape[0])
    steps = []
    for k0, k1 in step_segments(r[:m]):
        target = float(r[k0]) + offset
        model = predicted.values[k0:k1, j]
        start = float(y[k0]) if math.isfinite(y[k0]) else float(model[0])  # (a rig's gap)
        steps.append(
            StepComparison(
                output=output,
                t=k0 * Ts,
                span=(k1 - k0) * Ts,
                start=start,
                target=target,
                run=step_response_info(y[k0:k1], Ts, start, target),
                prediction=step_response_info(model, Ts, float(model[0]), target),
            )
        )
    return tuple(steps)


@dataclass(frozen=True)
class Comparison:
    """A recording against its prediction: samples ``compared``, the ``gaps`` per
    channel, the ``steps`` of its reference."""

    compared: int
    gaps: tuple[Gap, ...]
    steps: tuple[StepComparison, ...]


def compare(
    predicted: Predicted,
    names: Sequence[str],
    read: Callable[[int, int], Array],
    n: int,
    Ts: float,
    reference: tuple[str, float] | None = None,
) -> Comparison:
    """The first ``min(n, predicted)`` samples of the recording (``names`` its columns,
    ``read(k0, k1)`` its rows) against the prediction: the gap of each predicted channel
    recorded, over the samples measured (not those a rig dropped), and, given the
    ``reference`` output's name and operating point, each step of the recorded reference
    ``r`` (:func:`compare_steps`)."""
    m = min(n, predicted.values.shape[0])
    cols = [(j, names.index(name)) for j, name in enumerate(predicted.names) if name in names]
    follow = reference is not None and "r" in names and reference[0] in names
    r = np.empty(m if follow else 0)
    y = np.empty(m if follow else 0)
    sq = np.zeros(len(cols))
    seen = np.zeros(len(cols))  # samples measured (a rig's dropped ones are NaN)
    worst = np.zeros(len(cols))
    where = np.zeros(len(cols), dtype=np.int64)
    for k0 in range(0, m, PART):
        rows = read(k0, min(m, k0 + PART))
        k1 = k0 + rows.shape[0]
        if follow:
            assert reference is not None
            r[k0:k1] = rows[:, names.index("r")]
            y[k0:k1] = rows[:, names.index(reference[0])]
        for i, (j, c) in enumerate(cols):
            d = rows[:, c] - predicted.values[k0:k1, j]
            finite = np.isfinite(d)
            seen[i] += int(finite.sum())
            d = np.where(finite, d, 0.0)
            sq[i] += float(d @ d)
            if d.size == 0:
                continue
            a = int(np.argmax(np.abs(d)))
            if abs(d[a]) > worst[i]:
                worst[i], where[i] = abs(d[a]), k0 + a
    gaps = tuple(
        Gap(
            predicted.names[j],
            math.sqrt(sq[i] / seen[i]) if seen[i] else 0.0,
            float(worst[i]),
            float(where[i] * Ts),
        )
        for i, (j, _) in enumerate(cols)
    )
    if reference is None or not follow:
        return Comparison(m, gaps, ())
    return Comparison(m, gaps, compare_steps(predicted, reference[0], r, y, reference[1], Ts))


class Predictions:
    """The last ``keep`` predictions made, by key (a run and its changes so far), and
    those being made: two requests for the same prediction at once share one job."""

    def __init__(self, keep: int = 8) -> None:
        self.keep = keep
        self._done: OrderedDict[Hashable, Predicted] = OrderedDict()
        self._making: dict[Hashable, asyncio.Future[Predicted]] = {}

    async def get(self, key: Hashable, make: Callable[[], Awaitable[Predicted]]) -> Predicted:
        while (making := self._making.get(key)) is not None:
            try:  # shielded: this caller leaving does not cancel the other's job
                return await asyncio.shield(making)
            except asyncio.CancelledError:
                if not making.cancelled():
                    raise  # this caller was cancelled
                # the one making it left before it was made: make it here
        if (done := self._done.get(key)) is not None:
            self._done.move_to_end(key)
            return done
        future: asyncio.Future[Predicted] = asyncio.get_running_loop().create_future()
        self._making[key] = future
        try:
            made = await make()
        except asyncio.CancelledError:
            future.cancel()
            raise
        except Exception as exc:
            future.set_exception(exc)
            future.exception()  # retrieved: nobody else may be waiting
            raise
        finally:
            self._making.pop(key, None)
        future.set_result(made)
        self._done[key] = made
        while len(self._done) > self.keep:
            self._done.popitem(last=False)
        return made
