"""The predefined LQR closes the loop on the emulated rig through TcpDriver, as the
host loop will: stable, and a 30° step tracked within a few degrees.

The watchdog is set to 200 samples here: beside two busy processes on two cores this
test process is descheduled for over 50 ms now and then, which the real host loop (a
real-time process) must not be, and which the default 5 would rightly punish.
"""

from __future__ import annotations

import math

import numpy as np

from elab.plants.flexible_link import PLANT
from elab.rig.driver import RigSample, TcpDriver
from elab.rig.messages import Action, Status
from tests.unit.rig.emulator_process import running_emulator

K = np.array(PLANT.predefined.K)  # [20, -93.5614, 3.3621, 0.9623], seed eq. 4.6
STEP = math.radians(30)


def run_lqr(driver: TcpDriver, seconds: float) -> list[tuple[RigSample, float]]:
    """u = K (x_ref − x̂), x̂ = [θ, α, θ̇, α̇] with the velocity filters 150s/(s+150)
    and 50s/(s+50) (backward Euler over the samples' seq) and the step at 0.2 s."""
    Ts = driver.identity.Ts
    rows, prev, v = [], None, np.zeros(2)
    while len(rows) < seconds / Ts:
        s = driver.read(timeout=2.0)
        y = np.array([s.theta, s.alpha])
        if prev is not None:
            dt = (s.seq - prev.seq) * Ts  # a gap is a sample the rig dropped
            wc = np.array([150.0, 50.0])
            v = (v + wc * (y - np.array([prev.theta, prev.alpha]))) / (1 + wc * dt)
        prev = s
        r = STEP if len(rows) * Ts >= 0.2 else 0.0
        u = float(K @ (np.array([r, 0.0, 0.0, 0.0]) - np.concatenate([y, v])))
        u = min(max(u, -10.0), 10.0)
        driver.write(s.seq, u)
        rows.append((s, r))
    return rows


def _tracked_run() -> list[RigSample]:
    """The LQR's 2.2 s on a fresh emulator; tried again (three times at most) where the
    watchdog tripped: this test process is not real-time, and a machine busy enough
    deschedules it for over 200 ms now and then (a tripped rig is the right answer to
    that host, not a failure of the law; once in a chain of runs beside two CPU hogs)."""
    tripped = []
    for _ in range(3):
        with running_emulator("--rig-seed", "11", "--watchdog-samples", "200") as rig:
            driver = rig.driver()
            driver.connect()
            try:
                driver.command(Action.ZERO)
                driver.command(Action.ENABLE)
                samples = [s for s, _ in run_lqr(driver, 2.2)]
            finally:
                driver.close()
        late = [s.seq for s in samples if s.status & Status.WATCHDOG_TRIPPED]
        if not late:
            return samples
        tripped.append(late[0])
    raise AssertionError(f"the watchdog tripped in every try, at samples {tripped}")


def test_the_predefined_lqr_tracks_a_30_degree_step_on_the_emulated_rig() -> None:
    samples = _tracked_run()
    theta = np.array([s.theta for s in samples])
    alpha = np.array([s.alpha for s in samples])
    # stable: θ stays near the step (the seed's simulation overshoots by under 20 %)
    assert np.all(np.abs(theta) < 1.5 * STEP)
    assert np.all(np.abs(alpha) < math.radians(15))
    # tracked: over the last 0.3 s θ is within 3° of 30°: dead zone and Coulomb friction
    # (up to 0.3 V + 0.3 V against K[0] = 20 V/rad) leave at most about 1.7°
    last = theta[-300:]
    assert np.all(np.abs(last - STEP) < math.radians(3)), np.degrees(last[[0, -1]])
    assert np.all(np.abs(alpha[-300:]) < math.radians(2))
