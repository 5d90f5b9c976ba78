"""Every invalid run is refused with an error naming the field and what is allowed."""

from __future__ import annotations

import math

import pytest

from elab.errors import DimensionError, InvalidInput
from elab.laws import PID, LTIController, StateFeedback
from elab.plants import get_plant
from elab.sim import Chirp, RunSpec, Sine, Square, Step, UserSamples, compile_run

FLEX = get_plant("flexible_link")
PEND = get_plant("double_pendulum")


@pytest.mark.parametrize(
    ("spec", "field", "allowed"),
    [
        (RunSpec(FLEX, FLEX.predefined, Ts=0.0), "Ts", "> 0"),
        (RunSpec(FLEX, FLEX.predefined, Ts=-1e-3), "Ts", "> 0"),
        (RunSpec(FLEX, FLEX.predefined, Ts=float("nan")), "Ts", "finite"),
        (RunSpec(FLEX, FLEX.predefined, Ts=0.01), "Ts", "fastest pole"),
        (
            RunSpec(FLEX, StateFeedback((1.0, 2.0)), Ts=1e-3),
            "controller.K",
            "4 gains, one per state",
        ),
        (RunSpec(FLEX, StateFeedback((1.0, float("nan"), 0, 0))), "controller.K", "finite"),
        (RunSpec(FLEX, FLEX.predefined, duration=0.0), "duration", "(0, 3600]"),
        (RunSpec(FLEX, FLEX.predefined, duration=1e9), "duration", "(0, 3600]"),
        # a sample time so small that the run would not fit in memory, or its sample count
        # in a float (1e-300 raised numpy's "maximum allowed dimension", 5e-324 OverflowError)
        (RunSpec(FLEX, FLEX.predefined, Ts=1e-300), "Ts", "≥ 2.77778e-07 s for a 10 s run"),
        (RunSpec(FLEX, FLEX.predefined, Ts=5e-324), "Ts", "at most 36,000,000 samples"),
        (RunSpec(FLEX, FLEX.predefined, duration=3600, Ts=9e-5), "Ts", "≥ 0.0001 s"),
        # a reference of 1e308 failed its run as "diverged: the closed loop is unstable"
        (RunSpec(FLEX, FLEX.predefined, Step(1e308)), "signal.amplitude", "within ±1e+09"),
        (RunSpec(FLEX, FLEX.predefined, Step(6e8, offset=6e8)), "signal.amplitude", "±1e+09"),
        (
            RunSpec(FLEX, FLEX.predefined, excitation=UserSamples((0.0, -2e9))),
            "excitation.values",
            "offset ± amplitude",
        ),
        # a negative seed raised numpy's SeedSequence error from inside the stepping loop
        (RunSpec(FLEX, FLEX.predefined, noise_seed=-1), "noise_seed", "[0, 2^63 − 1]"),
        (RunSpec(FLEX, FLEX.predefined, noise_seed=2**63), "noise_seed", "[0, 2^63 − 1]"),
        # issue 15: 1e-9 s ran 1 sample; a period shorter than a few samples aliases
        (RunSpec(FLEX, FLEX.predefined, duration=1e-9), "duration", "≥ 0.01 s at Ts = 0.001"),
        (RunSpec(FLEX, FLEX.predefined, duration=0.02, Ts=0.0025), "duration", "≥ 0.025 s"),
        (RunSpec(FLEX, FLEX.predefined, Square(1.0, 0.003)), "signal.period", "≥ 0.004 s"),
        (RunSpec(FLEX, FLEX.predefined, Sine(1.0, 300.0)), "signal.frequency", "≤ 250 Hz"),
        (
            RunSpec(FLEX, FLEX.predefined, excitation=Chirp(1.0, 1.0, 251.0, 5.0)),
            "excitation.f1",
            "≤ 250 Hz (at least 4 samples per period",
        ),
        (RunSpec(FLEX, FLEX.predefined, u_max=-1.0), "u_max", "> 0"),
        (RunSpec(FLEX, PID(float("inf"))), "controller.Kp", "finite"),
        (
            RunSpec(FLEX, LTIController(num=(1.0, 2.0, 3.0), den=(1.0, 1.0))),
            "controller.num",
            "proper",
        ),
        (
            RunSpec(FLEX, LTIController(num=(1.0,), den=(1.0, 1.0), dt=0.002)),
            "controller.dt",
            "0.001",
        ),
        (RunSpec(FLEX, FLEX.predefined, x0=(0.0, 0.0)), "x0", "shape 4"),
        (
            RunSpec(PEND, PEND.predefined, x0=(0, math.radians(15), math.pi, 0, 0, 0)),
            "x0[1] (beta1)",
            "validity range",
        ),
        (
            RunSpec(PEND, PEND.predefined, x0=(0, 0, math.radians(100), 0, 0, 0)),
            "x0[2] (beta2)",
            "validity range",
        ),
    ],
)
def test_invalid_run_is_refused(spec: RunSpec, field: str, allowed: str) -> None:
    with pytest.raises(InvalidInput) as err:
        compile_run(spec)
    assert err.value.field == field
    assert allowed in err.value.allowed


def test_the_shortest_run_and_periods_are_allowed() -> None:
    run = compile_run(RunSpec(FLEX, FLEX.predefined, Square(1.0, 0.004), duration=0.01))
    assert run.n_samples == 10
    compile_run(RunSpec(FLEX, FLEX.predefined, Sine(1.0, 250.0), duration=0.01))


def test_wrong_dimension_is_a_dimension_error() -> None:
    with pytest.raises(DimensionError):
        compile_run(RunSpec(FLEX, StateFeedback((1.0,) * 6)))


def test_safe_initial_state_is_accepted() -> None:
    run = compile_run(
        RunSpec(
            PEND, PEND.predefined, Step(0.0), x0=(0, math.radians(5), math.radians(200), 0, 0, 0)
        )
    )
    assert run.x0[2] == pytest.approx(math.radians(20))  # stored as deviation from 180°


def test_too_coarse_sample_time_names_the_limit() -> None:
    with pytest.raises(InvalidInput, match=r"150 rad/s"):
        compile_run(RunSpec(FLEX, FLEX.predefined, Square(0.5, 4.0), Ts=0.005))
