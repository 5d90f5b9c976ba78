"""compile_run keeps each plant's discretised laws (elab/sim/spec.py, _DiscreteCache):
a run compiled again gives the bits a fresh discretisation gives; another plant (even one
equal but for a number), another law or another Ts is discretised anew; the kept arrays
cannot be written; a plant's entries go with it."""

from __future__ import annotations

import gc
import math
from dataclasses import replace

import numpy as np
import pytest

from elab.laws import StateFeedback
from elab.plants import get_plant
from elab.sim import RunSpec, Square, compile_run, simulate
from elab.sim import spec as spec_module

FLEX = get_plant("flexible_link")
SPEC = RunSpec(FLEX, FLEX.predefined, Square(math.radians(30), 2.0), duration=2.0, noise_seed=3)


def fresh(spec: RunSpec) -> np.ndarray:
    spec_module._DISCRETE._by.clear()
    s = simulate(spec)
    return np.column_stack([s.r, s.u, s.y, s.x])


def test_a_run_compiled_again_is_bit_for_bit_a_fresh_one() -> None:
    want = fresh(SPEC)
    first, again = compile_run(SPEC), compile_run(SPEC)
    assert again.Ad is first.Ad and again.controller is first.controller  # kept
    s = simulate(SPEC)
    assert np.array_equal(np.column_stack([s.r, s.u, s.y, s.x]), want)


def test_another_plant_law_or_sample_time_is_discretised_anew() -> None:
    base = compile_run(SPEC)
    A = np.array(FLEX.A, copy=True)
    A[np.unravel_index(np.argmax(np.abs(A)), A.shape)] *= 1.01  # its stiffest term
    other = replace(FLEX, A=A)
    assert not np.array_equal(compile_run(replace(SPEC, plant=other)).Ad, base.Ad)
    law = StateFeedback(K=(30.0, *FLEX.predefined.K[1:]), estimate=FLEX.predefined.estimate)
    assert not np.array_equal(compile_run(replace(SPEC, law=law)).controller.Dc, base.controller.Dc)
    slower = compile_run(replace(SPEC, Ts=2 * FLEX.Ts))
    assert not np.array_equal(slower.Ad, base.Ad)
    # and each of them is what a fresh discretisation gives
    for spec in (replace(SPEC, plant=other), replace(SPEC, law=law), replace(SPEC, Ts=2e-3)):
        kept = simulate(spec)
        assert np.array_equal(np.column_stack([kept.r, kept.u, kept.y, kept.x]), fresh(spec))


def test_kept_arrays_cannot_be_written() -> None:
    run = compile_run(SPEC)
    for a in (run.Ad, run.Bd, run.controller.Ac, run.controller.Dc, run.controller.Lw):
        with pytest.raises(ValueError, match="read-only"):
            a[...] = 0.0


def test_a_plants_entries_go_with_it() -> None:
    other = replace(FLEX, A=np.array(FLEX.A, copy=True))
    compile_run(replace(SPEC, plant=other))
    key = id(other)
    assert key in spec_module._DISCRETE._by
    del other
    gc.collect()
    held = spec_module._DISCRETE._by.get(key)
    assert held is None or held[0]() is not None  # gone, or the id is another live plant's
