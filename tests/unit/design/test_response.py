"""elab.design.response: step response and metrics, Bode data, stability margins."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest
from numpy.testing import assert_allclose

from elab.design import bode, closed_loop, margins, step_info, step_response
from elab.errors import InvalidInput
from elab.laws import PID
from elab.plants import PLANTS

FLEX = PLANTS["flexible_link"]
BELT = PLANTS["belt_conveyor"]


def test_step_response_of_a_first_order_lag_is_exact() -> None:
    sys = ct.ss([[-2.0]], [[2.0]], [[1.0]], [[0.0]], outputs=["y"])
    result = step_response(sys, 3.0, n=301, amplitude=0.5)
    # Analytic: y = a (1 - exp(-2 t)) for G = 2/(s + 2).
    assert_allclose(result.y[0], 0.5 * (1 - np.exp(-2 * result.t)), rtol=0, atol=1e-12)
    assert_allclose(result.u, 0.5)
    assert result.y.shape == (1, 301) and result.outputs == ("y",)


def test_step_response_of_a_closed_loop_returns_the_plant_input() -> None:
    loop = closed_loop(BELT, PID(12, 0.49, 0.5))
    result = step_response(loop, 5.0, n=501, u_output=-1)
    assert result.outputs == ("x", "v")
    assert result.y.shape == (2, 501) and result.u.shape == (501,)
    # At t = 0+ the PID acts on e = 1: u(0) = Kp + Kd / Tf = 12 + N Kp = 132 V.
    assert_allclose(result.u[0], 12 + 10 * 12, rtol=1e-12)


def test_step_response_rejects_bad_arguments() -> None:
    sys = ct.ss([[-1.0]], [[1.0]], [[1.0]], [[0.0]])
    with pytest.raises(InvalidInput, match=r"^T: "):
        step_response(sys, -1.0)
    with pytest.raises(InvalidInput, match=r"^n: "):
        step_response(sys, 1.0, n=1)
    with pytest.raises(InvalidInput, match=r"^sys: "):
        step_response(ct.ss(-np.eye(2), np.eye(2), np.eye(2), 0), 1.0)


def _second_order(zeta: float, omega_n: float) -> tuple[np.ndarray, np.ndarray]:
    sys = ct.tf([omega_n**2], [1, 2 * zeta * omega_n, omega_n**2])
    response = ct.step_response(sys, np.linspace(0, 20, 20001))
    return np.asarray(response.time), np.asarray(response.outputs)


def test_step_info_matches_python_control_on_a_second_order_system() -> None:
    t, y = _second_order(0.3, 2.0)
    info = step_info(t, y)
    reference = ct.step_info(y, timepts=t)  # python-control's own definitions
    assert_allclose(
        [
            info.rise_time,
            info.settling_time,
            info.overshoot,
            info.peak,
            info.peak_time,
            info.steady_state,
        ],
        [
            reference["RiseTime"],
            reference["SettlingTime"],
            reference["Overshoot"],
            reference["Peak"],
            reference["PeakTime"],
            reference["SteadyStateValue"],
        ],
        rtol=1e-3,
    )
    # Ogata §5-3: M_p = exp(-ζπ/√(1-ζ²)) = 37.23 %, t_p = π/(ω_n √(1-ζ²)) = 1.6467 s.
    assert_allclose(info.overshoot, 100 * np.exp(-0.3 * np.pi / np.sqrt(1 - 0.09)), rtol=1e-3)
    assert_allclose(info.peak_time, np.pi / (2.0 * np.sqrt(1 - 0.09)), rtol=1e-3)
    # The final sample at t = 20 s is within the envelope exp(-ζ ω_n t) = 6e-6 of 1.
    assert_allclose(info.steady_state_error, 0.0, atol=1e-5)


def test_step_info_of_a_divergent_response_is_nan_where_undefined() -> None:
    t = np.linspace(0, 10, 1001)
    info = step_info(t, np.exp(0.5 * t) - 1)
    assert np.isnan(
        [
            info.rise_time,
            info.settling_time,
            info.overshoot,
            info.steady_state,
            info.steady_state_error,
        ]
    ).all()
    assert_allclose([info.peak, info.peak_time], [np.exp(5.0) - 1, 10.0], rtol=1e-12)


def test_step_info_rejects_bad_data() -> None:
    with pytest.raises(InvalidInput, match=r"^t, rise: "):
        step_info([0.0, 1.0, 1.0], [0.0, 1.0, 1.0])
    with pytest.raises(InvalidInput, match=r"^y: "):
        step_info([0.0, 1.0], [0.0, 1.0, 2.0])
    with pytest.raises(InvalidInput, match=r"^settling: "):
        step_info([0.0, 1.0], [0.0, 1.0], settling=0.0)


def test_bode_matches_the_frequency_response_of_the_model() -> None:
    sys = ct.ss(FLEX.A, FLEX.B, FLEX.C, FLEX.D, outputs=["theta", "alpha"])
    result = bode(sys)
    G = np.array(
        [FLEX.C @ np.linalg.solve(1j * w * np.eye(4) - FLEX.A, FLEX.B) for w in result.omega]
    )[:, :, 0].T  # definition C (jωI - A)^-1 B
    assert_allclose(10 ** (result.mag_db / 20), np.abs(G), rtol=1e-9)
    expected = ct.frequency_response(sys, result.omega, squeeze=False)
    assert_allclose(10 ** (result.mag_db / 20), expected.magnitude[:, 0, :], rtol=1e-9)
    assert_allclose(np.exp(1j * np.radians(result.phase_deg)), G / np.abs(G), atol=1e-9)
    assert_allclose(result.hz, result.omega / (2 * np.pi), rtol=1e-15)
    assert result.outputs == ("theta", "alpha")


def test_bode_phase_is_unwrapped() -> None:
    result = bode(ct.tf([1], [1, 4, 6, 4, 1]))  # 1/(s + 1)^4: phase from 0 to -360°
    assert np.all(np.abs(np.diff(result.phase_deg[0])) < 10)
    # Analytic: ∠G = -4 atan(ω).
    assert_allclose(result.phase_deg[0], -4 * np.degrees(np.arctan(result.omega)), atol=1e-9)


def test_bode_default_grid_spans_two_decades_beyond_poles_and_zeros() -> None:
    result = bode(ct.tf([1, 10], [1, 101, 100]))  # zero 10, poles 1 and 100 rad/s
    assert_allclose([result.omega[0], result.omega[-1]], [1e-2, 1e4], rtol=1e-12)
    assert result.omega.size == 500


def test_bode_rejects_non_positive_frequencies() -> None:
    with pytest.raises(InvalidInput, match=r"^omega: "):
        bode(ct.tf([1], [1, 1]), omega=[0.0, 1.0])


def test_margins_of_a_third_order_loop() -> None:
    L = ct.tf([4], [1, 3, 3, 1])  # 4 / (s + 1)^3
    result = margins(L)
    # Analytic: ∠L = -180° at ω = √3 where |L| = 1/2 (6.02 dB); |L| = 1 at
    # ω = √(4^(2/3) - 1), phase margin 180° - 3 atan(ω).
    w_gc = np.sqrt(4 ** (2 / 3) - 1)
    assert_allclose(result.phase_crossover, np.sqrt(3), rtol=1e-6)
    assert_allclose(result.gain_margin_db, 20 * np.log10(2), rtol=1e-6)
    assert_allclose(result.gain_crossover, w_gc, rtol=1e-6)
    assert_allclose(result.phase_margin_deg, 180 - 3 * np.degrees(np.arctan(w_gc)), rtol=1e-6)
    gm, pm, _, wpc, wgc, _ = ct.stability_margins(L)
    assert_allclose(
        [
            result.gain_margin_db,
            result.phase_margin_deg,
            result.phase_crossover,
            result.gain_crossover,
        ],
        [20 * np.log10(gm), pm, wpc, wgc],
        rtol=1e-12,
    )


def test_margins_without_crossovers_are_infinite() -> None:
    result = margins(ct.tf([0.5], [1, 1]))
    assert result.gain_margin_db == np.inf and result.phase_margin_deg == np.inf
    assert np.isnan(result.gain_crossover) and np.isnan(result.phase_crossover)


def test_margins_reject_a_mimo_loop() -> None:
    with pytest.raises(InvalidInput, match=r"^L: "):
        margins(ct.ss(-np.eye(2), np.eye(2), np.eye(2), 0))
