"""The emulated rig's hardware without its process: hidden parameters per seed,
sensors, and the amplifier's watchdog as a state machine."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from elab.plants.flexible_link_nonlinear import NOMINAL
from elab.rig.hardware import Amplifier, Link, MotorState, draw_rig_parameters
from elab.rig.messages import Action, Status


def test_the_same_seed_is_the_same_rig_and_another_seed_another() -> None:
    assert draw_rig_parameters(3) == draw_rig_parameters(3)
    assert draw_rig_parameters(3) != draw_rig_parameters(4)


@pytest.mark.parametrize("seed", range(20))
def test_true_parameters_stay_within_the_documented_spreads(seed: int) -> None:
    p = draw_rig_parameters(seed)
    assert abs(p.plant.K_s / NOMINAL.K_s - 1) <= 0.10
    assert abs(p.plant.k_u / NOMINAL.k_u - 1) <= 0.08
    assert 0.01 <= p.plant.tau_c <= 0.04 and 0.05 <= p.plant.u_dead <= 0.3
    assert abs(p.gauge_offset) <= 40 and 0.5 <= p.gauge_noise_std <= 2.0


def test_the_encoder_counts_4096_per_turn_and_zero_re_zeroes_it() -> None:
    link = Link(draw_rig_parameters(0), 1e-3, noise_seed=0)
    link.x = np.array([math.pi / 2 + 1e-6, 0.0, 0.0, 0.0])
    assert link.measure()[0] == 1024
    link.zero()
    assert link.measure()[0] == 0


def test_the_gauge_reads_through_its_true_gain_offset_and_noise() -> None:
    p = draw_rig_parameters(5)
    link = Link(p, 1e-3, noise_seed=5)
    link.x = np.array([0.0, 0.03, 0.0, 0.0])
    readings = np.array([link.measure()[1] for _ in range(4000)])
    # mean of 4000 readings: noise/sqrt(4000) < 0.04 counts, rounding 0.5 counts at most
    assert_allclose(readings.mean(), 0.03 / p.gauge_rad_per_count + p.gauge_offset, atol=0.6)
    assert_allclose(readings.std(), math.hypot(p.gauge_noise_std, 12**-0.5), rtol=0.1)
    link.zero()
    tared = np.array([link.measure()[1] for _ in range(4000)])
    assert abs(tared.mean()) < 2.0  # tared on a noisy average of 16 readings


def test_the_watchdog_trips_after_the_set_number_of_silent_samples() -> None:
    amp = Amplifier(u_sat=10.0, watchdog_samples=5)
    assert amp.output == 0.0 and amp.status == Status(0)  # disabled at power-on
    amp.command(Action.ENABLE)
    amp.voltage(12.0)
    assert amp.output == 10.0
    assert amp.status == Status.MOTOR_ENABLED | Status.AMPLIFIER_SATURATED
    for _ in range(4):
        amp.sample_sent()
    assert amp.state is MotorState.ENABLED
    amp.sample_sent()
    assert amp.state is MotorState.TRIPPED and amp.output == 0.0
    assert amp.status == Status.WATCHDOG_TRIPPED
    amp.voltage(3.0)  # a voltage alone does not re-arm it
    assert amp.output == 0.0
    amp.command(Action.ENABLE)
    amp.voltage(3.0)
    assert amp.output == 3.0


def test_a_non_finite_voltage_does_not_feed_the_watchdog() -> None:
    amp = Amplifier(u_sat=10.0, watchdog_samples=2)
    amp.command(Action.ENABLE)
    amp.voltage(1.0)
    amp.sample_sent()
    amp.voltage(math.nan)
    amp.sample_sent()
    assert amp.state is MotorState.TRIPPED


def test_stop_and_a_lost_host_leave_0_V() -> None:
    amp = Amplifier(u_sat=10.0, watchdog_samples=5)
    amp.command(Action.ENABLE)
    amp.voltage(5.0)
    amp.command(Action.STOP)
    assert amp.output == 0.0 and amp.state is MotorState.DISABLED
    amp.command(Action.ENABLE)
    amp.voltage(5.0)
    amp.host_left()
    assert amp.output == 0.0 and amp.state is MotorState.DISABLED
