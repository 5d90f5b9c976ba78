"""The report against independent references: closed-loop poles and margins from
python-control built here from the plant's matrices (not through elab.design), the peak
control voltage from the analytic first instant of a step, and the warnings and problems a
student should see."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import control as ct
import numpy as np
import pytest

from elab.controllers import check, template
from elab.errors import InvalidInput
from elab.laws import PID, LTIController, StateFeedback
from elab.plants import PLANTS, get_plant

FLEX = get_plant("flexible_link")
BELT = get_plant("belt_conveyor")
ELAB = str(Path(sys.executable).parent / "elab")


def same_poles(got: tuple[complex, ...], want: np.ndarray, rel: float = 1e-7) -> None:
    want = np.sort_complex(np.asarray(want, dtype=complex))
    got_ = np.sort_complex(np.asarray(got, dtype=complex))
    assert got_.shape == want.shape
    np.testing.assert_allclose(got_, want, rtol=rel, atol=1e-9)


def test_true_state_feedback_poles_are_the_eigenvalues_of_a_minus_bk() -> None:
    K = np.array([[20.0, -93.5614, 3.3621, 0.9623]])
    r = check(FLEX, StateFeedback(tuple(K[0]), "true_state"))
    same_poles(r.poles, np.linalg.eigvals(FLEX.A - FLEX.B @ K))
    assert r.stable and r.rig_ready
    gm, pm, *_ = ct.stability_margins(ct.ss(FLEX.A, FLEX.B, K, 0))
    assert math.isinf(r.gain_margin_db or 0) == math.isinf(gm)
    assert r.phase_margin_deg == pytest.approx(pm, rel=1e-6)
    # at t = 0+ the state is 0 and u = K_θ r: the largest |u| of the step (seed: 30° → 10.5 V)
    amplitude = FLEX.signal.amplitude
    assert r.peak_u == pytest.approx(20.0 * amplitude, rel=1e-9)
    assert any("saturates" in w for w in r.warnings)  # 10.47 V against ±10 V


def test_a_pid_loop_has_the_poles_of_the_feedback_of_c_and_p() -> None:
    law = PID(12.0, 0.49, 0.5)  # the seed's conveyor PID
    P = ct.ss2tf(ct.ss(BELT.A, BELT.B, BELT.C[[BELT.reference_output]], 0))
    Tf = law.Kd / (law.N * law.Kp)
    C = ct.tf([law.Kp], [1]) + ct.tf([law.Ki], [1, 0]) + ct.tf([law.Kd, 0], [Tf, 1])
    want = ct.feedback(C * P, 1).poles()
    r = check(BELT, law)
    same_poles(r.poles, want, rel=1e-6)
    _, pm, *_ = ct.stability_margins(C * P)
    assert r.phase_margin_deg == pytest.approx(pm, rel=1e-6)


def test_an_unstable_loop_is_a_problem_for_the_rig_and_has_no_peak() -> None:
    r = check(FLEX, StateFeedback((-20.0, 0.0, 0.0, 0.0), "true_state"))
    assert not r.stable and not r.rig_ready and r.peak_u is None
    assert "unstable" in r.problems[0]
    assert "not for the rig" in r.text()


def test_a_discrete_controller_at_another_sample_time_is_a_problem() -> None:
    r = check(BELT, LTIController(num=(1.0,), den=(1.0, -0.5), dt=0.01))
    assert any("dt = 0.01 s" in p and "Ts = 0.001 s" in p for p in r.problems)


def test_a_discrete_controller_is_checked_on_the_zoh_model_at_its_sample_time() -> None:
    # the seed's conveyor PID by Tustin at 1 ms, as MATLAB's c2d(pid(12, 0.49, 0.5, Tf), Ts)
    law = PID(12.0, 0.49, 0.5)
    Tf = law.Kd / (law.N * law.Kp)
    C = ct.tf([law.Kp], [1]) + ct.tf([law.Ki], [1, 0]) + ct.tf([law.Kd, 0], [Tf, 1])
    Cd = ct.c2d(C, BELT.Ts, "tustin")
    num, den = np.ravel(Cd.num_array[0][0]), np.ravel(Cd.den_array[0][0])
    r = check(BELT, LTIController(num=tuple(num), den=tuple(den), dt=BELT.Ts))
    Pd = ct.c2d(ct.ss(BELT.A, BELT.B, BELT.C[[BELT.reference_output]], 0), BELT.Ts, "zoh")
    same_poles(r.poles, ct.feedback(ct.ss(Cd) * Pd, 1).poles(), rel=1e-6)
    assert r.domain == "z" and r.stable and r.rig_ready, r.text()
    # the same loop as the continuous PID's, sampled: its poles are exp(s Ts) of those
    cont = check(BELT, law)
    slow = sorted(abs(np.log(complex(z))) / BELT.Ts for z in r.poles)[:3]
    assert slow == pytest.approx(sorted(abs(p) for p in cont.poles)[:3], rel=1e-3)
    # the first sample (y = 0 yet) is the largest: u[0] = C(z → ∞) r = (b0 / a0) r
    assert r.peak_u == pytest.approx(abs(num[0] / den[0]) * BELT.signal.amplitude, rel=1e-9)


@pytest.mark.parametrize("plant_id", list(PLANTS))
def test_the_predefined_controllers_pass(plant_id: str) -> None:
    plant = get_plant(plant_id)
    r = check(plant, plant.predefined)
    assert r.stable and r.rig_ready, r.text()


def test_elab_check_prints_the_report_of_a_template(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    text = template(BELT, "toml").decode().replace("Kp = 1  #", "Kp = 12  #")
    path.write_text(text)
    out = subprocess.run(
        [ELAB, "check", str(path), "--plant", "belt_conveyor", "--json"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    import json

    got = json.loads(out)
    assert got["controller"]["Kp"] == 12 and got["stable"] and got["rig_ready"]
    bad = tmp_path / "bad.toml"
    bad.write_text('version = 1\nkind = "pid"\nKp = [1,\n')
    r = subprocess.run(
        [ELAB, "check", str(bad), "--plant", "belt_conveyor"], capture_output=True, text=True
    )
    assert r.returncode == 2 and "line 4, the end of the file" in r.stderr


@pytest.mark.parametrize(
    "law",
    [
        LTIController(num=(1e308, 2.0), den=(1.0, 1e-300), dt=0.001),  # found by hypothesis
        LTIController(num=(1e308,), den=(1.0, 0.5), dt=0.001),
        LTIController(num=(1.0,), den=(5e-324, 1.0), dt=0.001),
        StateFeedback((1e308, -93.5614, 3.3621, 0.9623)),
        # found by a longer random search: python-control's margins raised IndexError
        StateFeedback((1.0, -93.5614, 1.6462925590565576e111, 0.9623)),
        PID(Kp=1e308, Ki=1e308),
    ],
)
def test_numbers_that_overflow_the_report_name_the_controller(law: object) -> None:
    """Issue 24: such laws gave 500s (a spline fit of an infinite frequency response)."""
    plant = get_plant("flexible_link" if isinstance(law, StateFeedback) else "belt_conveyor")
    try:
        report = check(plant, law)  # type: ignore[arg-type]
    except InvalidInput as exc:
        assert exc.field == "controller"
    else:  # or a report whose every number is finite or a margin's "none"
        assert all(np.isfinite(p) for p in report.poles)


@pytest.mark.parametrize(("misses", "slow"), [(0, 0), (327, 0), (327, 2)])
def test_late_steps_are_counted_against_a_controller_only_when_it_was_slow(
    misses: int, slow: int
) -> None:
    """Issue 27: "327 late of 20,000 steps" under a law that takes microseconds. Late
    answers the machine made (the round trip) are said to be the machine's."""
    from dataclasses import replace

    from elab.controllers.report import LATE_NOT_SLOW
    from elab.laws import PID
    from elab.plants import get_plant

    base = check(get_plant("belt_conveyor"), PID(Kp=1.0, Ki=0.0, Kd=0.0))
    times = {"median_us": 40.0, "p99_us": 90.0, "max_us": 300.0, "round_trip_median_us": 120.0}
    report = replace(base, compute={**times, "steps": 20000, "misses": misses, "slow": slow})
    line = next(r for r in report.text().splitlines() if "compute time per step" in r)
    said = {
        (0, 0): "0 late of 20000",
        (327, 0): "327 late of 20000" + LATE_NOT_SLOW,
        (327, 2): "327 late of 20000, 2 of them slower than the deadline in the controller itself",
    }
    assert line.endswith(said[misses, slow]), line
    assert (LATE_NOT_SLOW in line) == (misses > 0 and slow == 0)
    assert ("slower than the deadline" in line) == (slow > 0)
