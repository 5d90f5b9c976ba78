"""The steps of a run's reference and the response's characteristics beside the
prediction's (elab/runs/prediction.py): the spans found in the recorded reference, and
characteristics equal to python-control's ``step_info`` of the same samples (an
independent implementation), measured from where the output was at the step."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest

from elab.runs.prediction import (
    MAX_STEPS,
    Predicted,
    compare_steps,
    step_response_info,
    step_segments,
)

TS = 0.001


def second_order(zeta: float, wn: float, n: int) -> np.ndarray:
    """The unit step response of wn² / (s² + 2 ζ wn s + wn²), sampled every TS."""
    _, y = ct.step_response(ct.tf([wn**2], [1, 2 * zeta * wn, wn**2]), np.arange(n) * TS)
    return np.asarray(y, dtype=np.float64)


def test_the_spans_are_where_the_reference_holds_a_value() -> None:
    square = np.repeat([0.5, -0.5, 0.5, -0.5], 1000)
    assert step_segments(square) == [(0, 1000), (1000, 2000), (2000, 3000), (3000, 4000)]
    assert step_segments(np.full(300, 0.2)) == [(0, 300)]  # a step from the start
    # a sine changes every sample: no step; a blip shorter than the minimum is left out
    assert step_segments(np.sin(np.arange(5000) * 0.01)) == []
    blip = np.r_[np.zeros(100), np.ones(5), np.zeros(100)]
    assert step_segments(blip, min_samples=20) == [(0, 100), (105, 205)]
    assert len(step_segments(np.repeat(np.arange(100.0) % 2, 50))) == MAX_STEPS
    assert step_segments(np.zeros(0)) == []


@pytest.mark.parametrize(("zeta", "wn"), [(0.2, 8.0), (0.5, 5.0), (0.7, 12.0), (1.2, 6.0)])
@pytest.mark.parametrize(("start", "target"), [(0.0, 1.0), (2.0, 5.0), (0.3, -0.4)])
def test_the_characteristics_are_python_controls_from_where_the_output_was(
    zeta: float, wn: float, start: float, target: float
) -> None:
    """A second-order response from ``start`` to ``target``: the same overshoot, rise
    and settling times as python-control's ``step_info`` of the unit response (the
    overshoot also the textbook's exp(−ζπ/√(1−ζ²))), its peak and steady state absolute."""
    unit = second_order(zeta, wn, 4000)
    y = start + (target - start) * unit
    info = step_response_info(y, TS, start, target)
    theirs = ct.step_info(unit, np.arange(unit.size) * TS)
    assert info is not None
    assert info.overshoot == pytest.approx(theirs["Overshoot"], abs=1e-9)
    if zeta < 1:
        textbook = 100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))
        # (from the last sample, not the limit: 0.2 % apart at ζ = 0.2 after 4 s)
        assert info.overshoot == pytest.approx(textbook, abs=0.5)
    assert info.rise_time == pytest.approx(theirs["RiseTime"], abs=1.5 * TS)
    assert info.settling_time == pytest.approx(theirs["SettlingTime"], abs=1.5 * TS)
    assert info.steady_state == pytest.approx(start + (target - start) * unit[-1], abs=1e-12)
    assert info.peak == pytest.approx(start + (target - start) * theirs["Peak"], abs=1e-9)
    assert info.steady_state_error == pytest.approx(target - info.steady_state, abs=1e-12)


def test_unmeasured_samples_are_left_out_and_too_few_give_nothing() -> None:
    y = second_order(0.4, 10.0, 3000)
    gappy = y.copy()
    gappy[500:520] = np.nan  # a rig's dropped samples, after the peak
    whole, holed = step_response_info(y, TS, 0.0, 1.0), step_response_info(gappy, TS, 0.0, 1.0)
    assert whole is not None and holed is not None
    assert holed.overshoot == pytest.approx(whole.overshoot, abs=1e-9)
    assert step_response_info(np.full(10, np.nan), TS, 0.0, 1.0) is None


def test_run_and_prediction_are_characterised_step_by_step() -> None:
    """A square reference of two steps; the "run" overshoots more than the "model": each
    step's characteristics come from its own samples, the second step measured from where
    each output was at it."""
    n = 3000
    r = np.repeat([1.0, -1.0], n // 2)
    run_unit, model_unit = second_order(0.3, 10.0, n // 2), second_order(0.8, 10.0, n // 2)
    run = np.r_[run_unit, run_unit[-1] - 2 * run_unit]
    model = np.r_[model_unit, model_unit[-1] - 2 * model_unit]
    predicted = Predicted(("u", "theta"), np.column_stack([np.zeros(n), model]), None, 0, ())
    steps = compare_steps(predicted, "theta", r, run, 0.0, TS)
    assert [(s.t, s.span, s.target) for s in steps] == [(0.0, 1.5, 1.0), (1.5, 1.5, -1.0)]
    for s, unit_run, unit_model in zip(
        steps, (run_unit, run_unit), (model_unit, model_unit), strict=True
    ):
        assert s.run is not None and s.prediction is not None
        assert s.run.overshoot == pytest.approx(
            ct.step_info(unit_run, np.arange(n // 2) * TS)["Overshoot"], abs=1e-6
        )
        assert s.prediction.overshoot == pytest.approx(
            ct.step_info(unit_model, np.arange(n // 2) * TS)["Overshoot"], abs=1e-6
        )
        assert s.run.overshoot > s.prediction.overshoot + 20
    assert steps[1].start == pytest.approx(run[n // 2])
    # an operating point moves the target, not the spans
    assert compare_steps(predicted, "theta", r, run, 0.5, TS)[0].target == 1.5
    assert compare_steps(predicted, "alpha", r, run, 0.0, TS) == ()  # not predicted
