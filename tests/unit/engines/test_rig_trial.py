"""The rig trial: a controller is tried on the nonlinear link of several rigs drawn across
the hardware's spread, through the supervisor, before it may drive the rig. The
predefined LQR passes on every one; laws that would hurt the link, references beyond its
arc and Python controllers that never answer do not, each with a reason."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from elab.engines.rigtrial import TRIAL_RIGS, rig_trial
from elab.laws import CodeController, StateFeedback
from elab.plants.flexible_link import PLANT
from elab.plants.flexible_link_nonlinear import rk4_floats, rk4_step
from elab.rig.hardware import draw_rig_parameters
from elab.sim import RunSpec, Square, Step


def test_the_predefined_lqr_passes_on_every_rig_drawn() -> None:
    spec = RunSpec(PLANT, PLANT.predefined, Square(math.radians(20), 2.0), duration=10.0)
    trial = rig_trial(spec)
    assert trial.passed and trial.problem() is None
    assert len(trial.outcomes) == len(TRIAL_RIGS) and trial.duration == 10.0
    for o in trial.outcomes:
        # the square's ±20° reached within the friction's few degrees, the gauge within
        # its limit, the voltage within the amplifier's
        assert 15.0 < math.degrees(o.peak_theta) < 25.0, o
        assert math.degrees(o.peak_alpha) < 15.0 and o.peak_u <= 10.0


def test_a_destabilising_law_trips_on_the_rig_model_with_its_reason() -> None:
    wrong = StateFeedback(tuple(-np.asarray(PLANT.predefined.K)), "velocity_filters")
    trial = rig_trial(RunSpec(PLANT, wrong, Step(math.radians(20)), duration=5.0))
    problem = trial.problem()
    assert not trial.passed and problem is not None
    assert "the supervisor trips on 5" in problem and "on rig 1" in problem, problem
    assert all(o.trip is not None and o.trip.t < 1.0 for o in trial.outcomes)


def test_a_reference_beyond_the_links_arc_is_refused_without_a_trial() -> None:
    # the trial tries 10 s; the reference leaves the arc at 30 s: refused all the same
    far = Square(math.radians(150), 60.0)
    trial = rig_trial(RunSpec(PLANT, PLANT.predefined, far, duration=40.0))
    problem = trial.problem()
    assert problem is not None and "reaches 150°" in problem and trial.outcomes == ()


NEVER_ANSWERS = """
class Controller:
    def step(self, t, y, r):
        while t > 0.1:
            pass
        return 0.0
"""


def test_a_python_controller_that_never_answers_fails_its_trial() -> None:
    spec = RunSpec(PLANT, CodeController(NEVER_ANSWERS, "stuck.py"), duration=2.0)
    trial = rig_trial(spec, rigs=TRIAL_RIGS[:1])
    problem = trial.problem()
    assert problem is not None and "did not answer within" in problem, problem


@given(
    x=st.tuples(*[st.floats(-3, 3, allow_nan=False)] * 4),
    u=st.floats(-15, 15, allow_nan=False),
    seed=st.integers(0, 50),
)
def test_the_trials_integrator_is_the_emulators_to_the_bit(
    x: tuple[float, float, float, float], u: float, seed: int
) -> None:
    p = draw_rig_parameters(seed).plant
    expected = rk4_step(np.array(x), u, 1e-3, p)
    assert np.array_equal(np.array(rk4_floats(x, u, 1e-3, p)), expected)
