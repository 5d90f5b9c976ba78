"""The emulated rig's hardware, without I/O: a flexible link whose true parameters are
drawn per rig, its sensors, and an amplifier with an enable line and a watchdog.

:mod:`elab.rig.emulator` puts a clock and a socket around these.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, replace
from typing import assert_never

import numpy as np

from elab.plants.flexible_link_nonlinear import NOMINAL, FlexibleLinkParameters, rk4_step
from elab.rig.messages import Action, Status

COUNTS_PER_REV = 4096  # SRV02 encoder "E" in quadrature
GAUGE_RAD_PER_COUNT = 3.0e-4  # rad per ADC count: the calibration a rig reports
SUBSTEPS = 4  # RK4 steps per sample


@dataclass(frozen=True)
class RigParameters:
    """One rig's true physics and sensors, hidden from users.

    ``gauge_rad_per_count`` and ``gauge_offset`` (counts) are the strain gauge's true
    gain and zero, which differ from the calibration the rig reports;
    ``gauge_noise_std`` is the gauge's white noise (counts).
    """

    plant: FlexibleLinkParameters
    gauge_rad_per_count: float
    gauge_offset: float
    gauge_noise_std: float


def draw_rig_parameters(rig_seed: int) -> RigParameters:
    """The true parameters of rig ``rig_seed``: the same seed, the same rig.

    Each is drawn uniformly around :data:`~elab.plants.flexible_link_nonlinear.NOMINAL`:
    ``K_s`` ±10 %, ``k_u`` ±8 %, ``J_eq`` and ``J_l`` ±5 %, ``B_eq`` ±10 %; link damping
    ``B_l`` 1–3·10⁻³ N m s/rad; Coulomb friction ``tau_c`` 0.01–0.04 N m (0.07–0.3 V of
    motor torque); dead zone ``u_dead`` 0.05–0.3 V; gauge gain ±3 % around its
    calibration, gauge offset ±40 counts, gauge noise 0.5–2 counts rms.
    """
    rng = np.random.default_rng([rig_seed, 0x5EED])

    def spread(value: float, fraction: float) -> float:
        return value * float(rng.uniform(1 - fraction, 1 + fraction))

    plant = replace(
        NOMINAL,
        K_s=spread(NOMINAL.K_s, 0.10),
        k_u=spread(NOMINAL.k_u, 0.08),
        J_eq=spread(NOMINAL.J_eq, 0.05),
        J_l=spread(NOMINAL.J_l, 0.05),
        B_eq=spread(NOMINAL.B_eq, 0.10),
        B_l=float(rng.uniform(1e-3, 3e-3)),
        tau_c=float(rng.uniform(0.01, 0.04)),
        u_dead=float(rng.uniform(0.05, 0.3)),
    )
    return RigParameters(
        plant=plant,
        gauge_rad_per_count=spread(GAUGE_RAD_PER_COUNT, 0.03),
        gauge_offset=float(rng.uniform(-40, 40)),
        gauge_noise_std=float(rng.uniform(0.5, 2.0)),
    )


class Link:
    """The link's state and sensors: integrates, measures, re-zeroes."""

    def __init__(self, params: RigParameters, Ts: float, noise_seed: int) -> None:
        self.params = params
        self.Ts = Ts
        self.x = np.zeros(4)  # θ, α, θ̇, α̇ (rad, rad/s)
        self.theta_zero = 0.0  # rad, where the encoder reads 0
        self.gauge_tare = 0.0  # counts subtracted from the gauge after ZERO
        self._rng = np.random.default_rng([noise_seed, 0x6A06E])

    def advance(self, u: tuple[float, ...]) -> None:
        """Integrate one sample period with ``u[j]`` (V) held on substep ``j``."""
        h = self.Ts / len(u)
        for u_j in u:
            self.x = rk4_step(self.x, u_j, h, self.params.plant)

    def measure(self) -> tuple[int, int]:
        """Encoder counts (quantised, floor) and the gauge reading (counts, noisy)."""
        counts = math.floor((self.x[0] - self.theta_zero) * COUNTS_PER_REV / (2 * math.pi))
        noise = float(self._rng.normal(0.0, self.params.gauge_noise_std))
        return counts, round(self._gauge_level() + noise - self.gauge_tare)

    def zero(self) -> None:
        """Encoder to 0 here; the gauge tared on a 16-reading average (so not exactly)."""
        self.theta_zero = float(self.x[0])
        mean_noise = float(self._rng.normal(0.0, self.params.gauge_noise_std / 4))
        self.gauge_tare = self._gauge_level() + mean_noise

    def _gauge_level(self) -> float:
        p = self.params
        return float(self.x[1]) / p.gauge_rad_per_count + p.gauge_offset


class MotorState(enum.Enum):
    DISABLED = "disabled"  # at power-on, after STOP and after the host left
    ENABLED = "enabled"
    TRIPPED = "tripped"  # the watchdog fired; ENABLE clears it


class Amplifier:
    """The amplifier's enable line and watchdog: 0 V unless enabled and fed.

    The watchdog counts the samples sent since the host's last voltage; after
    ``watchdog_samples`` of them it trips: 0 V and :attr:`Status.WATCHDOG_TRIPPED`
    until ENABLE.
    """

    def __init__(self, u_sat: float, watchdog_samples: int) -> None:
        self.u_sat = u_sat
        self.watchdog_samples = watchdog_samples
        self.state = MotorState.DISABLED
        self.u = 0.0  # V, the host's last voltage
        self.silent = 0  # samples sent since the last voltage

    @property
    def output(self) -> float:
        """The voltage at the motor (V), clipped at the amplifier's limit."""
        if self.state is not MotorState.ENABLED:
            return 0.0
        return min(max(self.u, -self.u_sat), self.u_sat)

    @property
    def status(self) -> Status:
        match self.state:
            case MotorState.ENABLED:
                saturated = abs(self.u) > self.u_sat
                return Status.MOTOR_ENABLED | (Status.AMPLIFIER_SATURATED if saturated else 0)
            case MotorState.TRIPPED:
                return Status.WATCHDOG_TRIPPED
            case MotorState.DISABLED:
                return Status(0)
            case _:
                assert_never(self.state)

    def voltage(self, u: float) -> None:
        """The host's voltage; a non-finite one is ignored (it does not feed the watchdog)."""
        if math.isfinite(u):
            self.u = u
            self.silent = 0

    def sample_sent(self) -> None:
        self.silent += 1
        if self.state is MotorState.ENABLED and self.silent >= self.watchdog_samples:
            self.state = MotorState.TRIPPED

    def command(self, action: Action) -> None:
        """ENABLE or STOP (ZERO is the link's business, not the amplifier's)."""
        match action:
            case Action.ENABLE:
                self.state, self.u, self.silent = MotorState.ENABLED, 0.0, 0
            case Action.STOP:
                self.state, self.u = MotorState.DISABLED, 0.0
            case Action.ZERO:
                pass
            case _:
                assert_never(action)

    def host_left(self) -> None:
        self.state, self.u, self.silent = MotorState.DISABLED, 0.0, 0
