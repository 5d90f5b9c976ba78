"""The rig loop's controllers without the rig: a Python controller in its sandbox asks
for the same voltages as its declarative twin, sample by sample, given the same measured
angles (the loop's timing aside: test_rig_engine.py has the rig)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from elab.controllers.templates import python_source
from elab.engines.riglaw import compile_for_rig, law_for
from elab.engines.settings import CodeSettings
from elab.errors import InvalidInput
from elab.laws import CodeController, StateFeedback
from elab.plants.flexible_link import PLANT
from elab.sim import RunSpec, Square


def test_a_python_controller_asks_what_its_declarative_twin_does() -> None:
    signal = Square(math.radians(20), 0.2)
    declarative = law_for(compile_for_rig(RunSpec(PLANT, PLANT.predefined, signal, duration=1)))
    code = CodeController(python_source(PLANT, PLANT.predefined), "lqr.py")
    run = compile_for_rig(RunSpec(PLANT, code, signal, duration=1.0))
    python = law_for(run, CodeSettings(deadline=5.0))  # no answer is late here
    try:
        rng = np.random.default_rng(3)
        for k in range(600):
            t = k * run.Ts
            r = float(run.exogenous(k, 1)[0, 0])
            theta, alpha = rng.normal(0, 0.3), rng.normal(0, 0.05)
            a, late_a = declarative.u(t, r, 0.0, theta, alpha)
            b, late_b = python.u(t, r, 0.0, theta, alpha)
            assert not late_a and not late_b
            assert a == pytest.approx(b, abs=1e-9), k
    finally:
        python.close()
        declarative.close()


def test_a_law_that_needs_the_true_state_cannot_run_on_the_rig() -> None:
    law = StateFeedback(PLANT.predefined.K, "true_state")
    with pytest.raises(InvalidInput, match="never the true state"):
        compile_for_rig(RunSpec(PLANT, law, duration=1.0))
