"""elab.design.plant_loop: every control law closed around every plant, loop transfers."""

from __future__ import annotations

import dataclasses
from typing import Any

import control as ct
import numpy as np
import pytest
from numpy.testing import assert_allclose

from elab.design import (
    closed_loop,
    design_lqr,
    loop_transfer,
    pid_tf,
    stability,
    step_info,
    step_response,
)
from elab.errors import DimensionError, InvalidInput
from elab.laws import PID, LTIController, OpenLoop, StateFeedback
from elab.plants import PLANTS, VelocityFilter
from elab.plants.base import frozen_matrix

FLEX = PLANTS["flexible_link"]
BELT = PLANTS["belt_conveyor"]
K_SEED = (20.0, -93.5614, 3.3621, 0.9623)  # seed eq. 4.6


def _poles(sys: Any) -> np.ndarray:
    return np.sort_complex(np.linalg.eigvals(sys.A))


@pytest.mark.parametrize("plant", PLANTS.values(), ids=list(PLANTS))
def test_predefined_controller_gives_an_asymptotically_stable_loop(plant: Any) -> None:
    loop = closed_loop(plant, plant.predefined)
    assert stability(loop.A).verdict == "asymptotically stable"
    assert list(loop.output_labels) == [o.name for o in plant.outputs] + [plant.inputs[0].name]
    assert list(loop.input_labels) == ["r"]


def test_flexible_link_true_state_loop_has_the_lqr_poles(seed_facts: dict[str, Any]) -> None:
    facts = seed_facts["flexible_link"]["lqr"]
    expected = np.sort_complex([complex(p) for p in facts["closed_loop_poles_recomputed"]])
    designed = design_lqr(FLEX, facts["Q"], facts["R"]).K[0]
    # seed_facts closed_loop_poles_recomputed, printed to 5 decimals.
    assert_allclose(
        _poles(closed_loop(FLEX, StateFeedback(tuple(designed)))), expected, rtol=0, atol=1e-5
    )
    # With the seed's 4-decimal gain the poles move by at most 2.2e-3 (1.6e-5 relative).
    assert_allclose(_poles(closed_loop(FLEX, StateFeedback(K_SEED))), expected, rtol=1e-4)


def test_true_state_loop_is_a_minus_b_k() -> None:
    loop = closed_loop(FLEX, StateFeedback(K_SEED))
    K = np.array([K_SEED])
    # Definition u = K (e_i r - x): A_cl = A - B K, B_cl = B K e_i, u row = [-K | K e_i].
    assert_allclose(loop.A, FLEX.A - FLEX.B @ K, rtol=1e-15)
    assert_allclose(loop.B, FLEX.B * K_SEED[0], rtol=1e-15)
    assert_allclose(loop.C[-1], -K[0], rtol=1e-15)
    assert_allclose(loop.D[-1, 0], K_SEED[0], rtol=1e-15)


def test_flexible_link_lqr_tracks_theta_with_unit_dc_gain() -> None:
    loop = closed_loop(FLEX, StateFeedback(K_SEED))
    # A e_θ = 0 (θ is an integrator), so x = e_θ r is the equilibrium: θ/r = 1, α/r = 0, u = 0.
    assert_allclose(np.asarray(loop.dcgain())[:, 0], [1.0, 0.0, 0.0], rtol=0, atol=1e-9)


def _with_fast_filters(omega_c: float) -> Any:
    return dataclasses.replace(
        FLEX, velocity_filters=(VelocityFilter(2, 0, omega_c), VelocityFilter(3, 1, omega_c))
    )


def test_velocity_filter_loop_converges_to_the_true_state_loop() -> None:
    true_poles = _poles(closed_loop(FLEX, StateFeedback(K_SEED)))
    errors = []
    for omega_c in (1e4, 1e5):
        loop = closed_loop(_with_fast_filters(omega_c), StateFeedback(K_SEED, "velocity_filters"))
        assert loop.nstates == FLEX.nx + 2
        slow = np.sort_complex(_poles(loop)[np.abs(_poles(loop)) < 1e3])
        errors.append(np.max(np.abs(slow - true_poles) / np.abs(true_poles)))
    # The filters 1/(1 + s/ω_c) perturb the loop by O(|p|/ω_c): 1e-2 at ω_c = 1e5 rad/s,
    # and the error shrinks with ω_c like 1/ω_c.
    assert errors[1] < 1e-2
    assert_allclose(errors[0] / errors[1], 10.0, rtol=0.2)


def test_velocity_filter_estimate_is_the_band_limited_derivative() -> None:
    loop = closed_loop(FLEX, StateFeedback((0, 0, 1.0, 0), "velocity_filters"))
    # With K = e_θ̇ and r = 0: u = -150 s/(s + 150) θ. Check the loop's filter block:
    # filter state z' = -150 z + 150 θ and u = -150 (θ - z).
    z = list(loop.state_labels).index("theta_dot_filter")
    assert_allclose(loop.A[z, [0, z]], [150.0, -150.0], rtol=1e-15)
    assert_allclose(loop.C[-1, [0, z]], [-150.0, 150.0], rtol=1e-15)


def test_velocity_filters_need_every_state_measured_or_filtered() -> None:
    theta_only = dataclasses.replace(
        FLEX,
        C=frozen_matrix([[1, 0, 0, 0]]),
        D=frozen_matrix([[0]]),
        outputs=FLEX.outputs[:1],
        velocity_filters=(VelocityFilter(2, 0, 150.0),),
    )
    with pytest.raises(InvalidInput, match=r"^controller\.estimate: .*alpha"):
        closed_loop(theta_only, StateFeedback(K_SEED, "velocity_filters"))


def test_state_feedback_checks_the_gain_length() -> None:
    with pytest.raises(DimensionError, match=r"^controller\.K: .*4 gains"):
        closed_loop(FLEX, StateFeedback((1.0, 2.0, 3.0)))


def test_belt_conveyor_tuned_pid_is_quick() -> None:
    response = step_response(closed_loop(BELT, PID(12, 0.49, 0.5)), 20.0, n=4001, u_output=-1)
    info = step_info(response.t, response.y[0])
    # Seed §4.3 "pid_example": Kp = 12, Ki = 0.49, Kd = 0.5 gives a quick response.
    assert info.rise_time < 1.0
    assert info.overshoot < 5.0
    assert info.settling_time < 2.0


def test_belt_conveyor_predefined_pid_is_stable_but_slow() -> None:
    loop = closed_loop(BELT, BELT.predefined)
    response = step_response(loop, 80.0, n=8001, u_output=-1)
    info = step_info(response.t, response.y[0])
    # Seed §4.3: the predefined controller is "stable but slow".
    assert stability(loop.A).verdict == "asymptotically stable"
    assert info.rise_time > 5.0


def test_pid_loop_equals_unity_feedback_of_c_times_p() -> None:
    law = PID(12, 0.49, 0.5)
    P = ct.ss(BELT.A, BELT.B, BELT.C[:1], BELT.D[:1])
    T = ct.feedback(pid_tf(law) * P, 1)  # textbook r -> y = CP / (1 + CP)
    loop = closed_loop(BELT, law)
    omega = np.logspace(-2, 3, 40)
    expected = T(1j * omega)
    actual = ct.frequency_response(loop[0, 0], omega).complex
    assert_allclose(actual, expected, rtol=1e-9)


def test_lti_controller_in_tf_and_ss_form_give_the_same_loop() -> None:
    as_tf = LTIController(num=(2.0, 6.0), den=(1.0, 10.0))  # lead 2 (s + 3) / (s + 10)
    as_ss = LTIController(A=((-10.0,),), B=((1.0,),), C=((-14.0,),), D=((2.0,),))  # 2 - 14/(s+10)
    omega = np.logspace(-1, 2, 20)
    responses = [
        ct.frequency_response(closed_loop(BELT, law)[0, 0], omega).complex for law in (as_tf, as_ss)
    ]
    assert_allclose(responses[0], responses[1], rtol=1e-9)


@pytest.mark.parametrize(
    ("law", "field"),
    [
        (LTIController(num=(1.0,), den=(1.0, 1.0), dt=0.01), "controller.dt"),
        (LTIController(num=(1.0, 0.0, 0.0), den=(1.0, 1.0)), "controller.num"),
        (LTIController(num=(1.0,)), "controller"),
        (LTIController(A=((1.0, 0.0),), B=((1.0,),), C=((1.0,),), D=((0.0,),)), "controller.A"),
        (PID(1.0, 0.0, 1.0, N=0.0), "controller.N"),
        (PID(-1.0, 0.0, 1.0), "controller.Kd"),
        (PID(float("nan")), "controller.Kp"),
    ],
)
def test_bad_controllers_are_rejected_naming_the_field(law: Any, field: str) -> None:
    with pytest.raises(InvalidInput) as caught:
        closed_loop(BELT, law)
    assert caught.value.field == field
    assert str(caught.value).startswith(f"{field}: ")


def test_open_loop_is_the_plant_with_its_input_appended() -> None:
    loop = closed_loop(BELT, OpenLoop())
    assert_allclose(loop.A, BELT.A, rtol=0)
    assert_allclose(loop.C, np.vstack([BELT.C, np.zeros((1, 4))]), rtol=0)
    assert_allclose(loop.D[:, 0], [0.0, 0.0, 1.0], rtol=0)
    with pytest.raises(InvalidInput, match=r"^law: "):
        loop_transfer(BELT, OpenLoop())


def test_loop_transfer_of_state_feedback_is_k_resolvent_b() -> None:
    L = loop_transfer(FLEX, StateFeedback(K_SEED))
    for s in (0.5j, 3.0 + 2.0j, 40j):
        expected = np.array(K_SEED) @ np.linalg.solve(s * np.eye(4) - FLEX.A, FLEX.B)  # K(sI-A)⁻¹B
        assert_allclose(L(s), expected[0], rtol=1e-9)


def test_loop_transfer_of_pid_is_c_times_p_ref() -> None:
    law = PID(12, 0.49, 0.5)
    L = loop_transfer(BELT, law)
    C = pid_tf(law)
    for s in (0.5j, 3.0 + 2.0j, 40j):
        P = BELT.C[0] @ np.linalg.solve(s * np.eye(4) - BELT.A, BELT.B)  # y_ref / u
        assert_allclose(L(s), C(s) * P[0], rtol=1e-9)


def test_pid_tf_terms_and_filter_time() -> None:
    # Kp = 0: T_f = 0.01 s; C(s) = Ki/s + Kd s/(0.01 s + 1).
    C = pid_tf(PID(0.0, 2.0, 0.5))
    s = 1.0 + 1.0j
    assert_allclose(C(s), 2.0 / s + 0.5 * s / (0.01 * s + 1), rtol=1e-12)
    # Zero gains add no poles: PI has one pole (at 0), P none.
    assert len(pid_tf(PID(1.0, 0.05)).poles()) == 1
    assert len(pid_tf(PID(3.0)).poles()) == 0
