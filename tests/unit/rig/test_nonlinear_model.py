"""The nonlinear flexible link: its small-signal limit is the seed's model, its friction
and dead zone do what they are named for."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from elab.errors import InvalidInput
from elab.plants.flexible_link import PLANT
from elab.plants.flexible_link_nonlinear import NOMINAL, amplifier, f, rk4_step

LINEAR = dataclasses.replace(NOMINAL, tau_c=0.0, u_dead=0.0, B_l=0.0)
ROUGH = dataclasses.replace(NOMINAL, tau_c=0.02, u_dead=0.3, B_l=2e-3)


def jacobians(h: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Central differences of f at x = 0, u = 0."""
    x0 = np.zeros(4)
    A = np.column_stack(
        [
            (f(0.0, x0 + h * e, 0.0, LINEAR) - f(0.0, x0 - h * e, 0.0, LINEAR)) / (2 * h)
            for e in np.eye(4)
        ]
    )
    B = (f(0.0, x0, h, LINEAR) - f(0.0, x0, -h, LINEAR)) / (2 * h)
    return A, B.reshape(4, 1)


def test_the_small_signal_limit_is_the_seeds_linear_model() -> None:
    A, B = jacobians()
    # f is linear here, so central differences are exact up to rounding: 1e-6 relative
    # to the largest entry (the seed's A and B, §4.1.1)
    assert_allclose(A, PLANT.A, rtol=1e-6, atol=1e-6 * 921.77)
    assert_allclose(B, PLANT.B, rtol=1e-6, atol=1e-6 * 65.113)


def test_the_nominal_inertias_are_physical() -> None:
    # J_l against the 65 g, 0.381 m link as a rod about its end (Quanser FLEXGAGE): 10 %
    assert_allclose(NOMINAL.J_l, 0.065 * 0.381**2 / 3, rtol=0.10)


@pytest.mark.parametrize("theta_dot", [-2.0, -0.5, 0.5, 2.0])
def test_coulomb_friction_opposes_motion(theta_dot: float) -> None:
    x = np.array([0.0, 0.0, theta_dot, 0.0])
    smooth = f(0.0, x, 0.0, dataclasses.replace(ROUGH, tau_c=0.0))
    rough = f(0.0, x, 0.0, ROUGH)
    extra = (rough[2] - smooth[2]) * ROUGH.J_eq  # the friction torque, N m
    assert math.copysign(1.0, extra) == -math.copysign(1.0, theta_dot)
    # away from zero speed the smoothed friction is the full Coulomb torque (tanh(25) = 1)
    assert_allclose(abs(extra), ROUGH.tau_c, rtol=1e-9)


def test_friction_dissipates_a_free_swing() -> None:
    """With no input, energy only decreases (seed's model has no source but u)."""

    def energy(x: np.ndarray) -> float:
        theta_dot, alpha, alpha_dot = x[2], x[1], x[3]
        kinetic = ROUGH.J_eq * theta_dot**2 + ROUGH.J_l * (theta_dot + alpha_dot) ** 2
        return float(0.5 * kinetic + 0.5 * ROUGH.K_s * alpha**2)

    x = np.array([0.0, 0.05, 1.0, 0.0])
    e = [energy(x)]
    for _ in range(2000):
        x = rk4_step(x, 0.0, 2.5e-4, ROUGH)
        e.append(energy(x))
    assert e[-1] < 0.1 * e[0]
    # RK4's own error allows tiny rises step to step: 1e-9 J on about 2e-3 J
    assert np.all(np.diff(e) < 1e-9)


@pytest.mark.parametrize("u", [-0.29, -0.1, 0.0, 0.1, 0.29])
def test_no_torque_inside_the_dead_zone(u: float) -> None:
    assert amplifier(u, ROUGH) == 0.0
    x = np.zeros(4)
    assert_allclose(f(0.0, x, u, ROUGH), np.zeros(4), atol=0.0)


def test_the_dead_zone_and_the_saturation_shape_the_voltage() -> None:
    assert_allclose(amplifier(1.3, ROUGH), 1.0, rtol=1e-12)
    assert_allclose(amplifier(-1.3, ROUGH), -1.0, rtol=1e-12)
    assert_allclose(amplifier(25.0, ROUGH), ROUGH.u_sat - ROUGH.u_dead, rtol=1e-12)
    assert_allclose(amplifier(-25.0, LINEAR), -LINEAR.u_sat, rtol=1e-12)


def test_rk4_matches_the_linear_model_exactly_discretised() -> None:
    from scipy.linalg import expm

    h, u = 2.5e-4, 1.0
    x = np.array([0.1, 0.01, 0.0, 0.0])
    M = expm(np.block([[PLANT.A, PLANT.B], [np.zeros((1, 5))]]) * h)
    expected = M[:4, :4] @ x + M[:4, 4] * u
    # RK4's local error is O((h |λ|)^5) with |λ| < 35 1/s: far below 1e-9 relative
    assert_allclose(rk4_step(x, u, h, LINEAR), expected, rtol=1e-9, atol=1e-12)


def test_parameters_name_the_bad_field() -> None:
    with pytest.raises(
        InvalidInput, match=r"parameters\.K_s: got -1; allowed: a finite number > 0"
    ):
        dataclasses.replace(NOMINAL, K_s=-1.0)
