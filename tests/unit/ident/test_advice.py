"""Verdicts on identification data and models (elab.ident.advice), checked against what
is known of the data by construction: open or closed loop, the input's excitation, the
noise added, a model's stability and fit; the residual tests' false alarms at their
stated level."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import control as ct
import numpy as np
import pytest

from elab.ident.advice import FEEDBACK_SHARE, excitation_order, feedback, on_data, snr_db, worst
from elab.ident.data import IdData
from elab.ident.modeladvice import Physics, _zeros, on_physics, physics_gap
from elab.ident.models import LinearModel
from elab.ident.parameters import ArmaxParameters, ArxParameters
from elab.ident.pem import armax
from elab.ident.polynomial import arx
from elab.ident.validation import resid
from elab.ident.workflow import ModelRequest, Plan, run
from elab.plants import get_plant

REFERENCE = Path(__file__).parents[2] / "reference" / "ident"
N = 2000


def prbs(rng: np.random.Generator, hold: int = 5) -> np.ndarray:
    return np.repeat(np.sign(rng.standard_normal(N // hold + 1)), hold)[:N]


def first_order(
    rng: np.random.Generator, noise: float, gain: float | None = None, equation: bool = False
) -> tuple[IdData, float]:
    """y = 0.5 q⁻¹ / (1 − 0.9 q⁻¹) u + e (a sensor's white noise; ``equation``: the ARX
    form y(t) = 0.9 y(t−1) + 0.5 u(t−1) + e(t)), in open loop (``gain`` None: u a PRBS)
    or closed by u = r − gain·y with r the PRBS; and the true signal-to-noise ratio (dB)."""
    r, e = prbs(rng), noise * rng.standard_normal(N)
    y, clean, u = np.zeros(N), np.zeros(N), np.zeros(N)
    for t in range(N):
        if t:
            clean[t] = 0.9 * clean[t - 1] + 0.5 * u[t - 1]
            carried = y[t - 1] if equation else y[t - 1] - e[t - 1]
            y[t] = 0.9 * carried + 0.5 * u[t - 1] + e[t]
        else:
            y[t] = e[t]
        u[t] = r[t] if gain is None else r[t] - gain * y[t]
    if gain is None:
        snr = 10 * math.log10(np.var(clean) / noise**2) if noise else math.inf
    else:
        snr = math.nan
    return IdData(y[:, None], u[:, None], 0.01, ("y",), ("u",)), snr


@pytest.mark.parametrize("seed", range(10))
def test_feedback_is_found_in_closed_loop_and_not_in_open_loop(seed: int) -> None:
    rng = np.random.default_rng(seed)
    open_loop, _ = first_order(rng, 0.2)
    closed, _ = first_order(rng, 0.2, gain=1.5)
    assert feedback(open_loop) < FEEDBACK_SHARE  # not significant, or too small to bias
    assert on_data(open_loop, 0, 0, None)[0].level == "good"
    assert feedback(closed) > 0.1
    verdict = on_data(closed, 0, 0, None)[0]
    assert verdict.topic == "feedback" and verdict.level == "caution"
    assert "closed loop" in verdict.finding and verdict.advice


def test_the_order_of_excitation_is_that_of_the_signal() -> None:
    rng = np.random.default_rng(1)
    k = np.arange(N)
    assert excitation_order(rng.standard_normal((N, 1))) == 40  # all it looks for
    assert excitation_order(prbs(rng)[:, None]) == 40
    assert excitation_order(np.sin(0.5 * k)[:, None]) == 2
    assert excitation_order(np.sin(0.5 * k)[:, None] + np.sin(2.0 * k)[:, None]) == 4
    assert excitation_order((k >= N // 2).astype(float)[:, None]) <= 2
    assert excitation_order(np.ones((N, 1))) == 0


def test_a_step_cannot_pin_down_a_fourth_order_model_and_the_verdict_says_so() -> None:
    rng = np.random.default_rng(2)
    z, _ = first_order(rng, 0.01)
    step = IdData(z.y, (np.arange(N) >= N // 2).astype(float)[:, None], z.Ts, ("y",), ("u",))
    excitation = next(v for v in on_data(step, 20, 4, None) if v.topic == "excitation")
    assert excitation.level == "poor" and "order 4 was asked" in excitation.finding
    assert excitation.advice is not None and "PRBS" in excitation.advice


@pytest.mark.parametrize("noise", [0.02, 0.1, 0.5])
def test_the_signal_to_noise_ratio_is_within_2_db_of_the_truth(noise: float) -> None:
    z, truth = first_order(np.random.default_rng(3), noise)
    estimate = snr_db(z)
    assert estimate is not None and abs(estimate - truth) < 2.0, (estimate, truth)
    level = next(v for v in on_data(z, 0, 0, None) if v.topic == "noise").level
    assert level == ("good" if truth >= 20 else "caution" if truth >= 10 else "poor")


def test_residual_tests_fail_a_right_model_about_one_time_in_a_hundred() -> None:
    """The band test ("every lag inside 99 %") failed one good model in three; the χ²
    tests fail at their level: at most 3 of 40 right models here, and every wrong one."""
    wrong_ones, false_alarms = 0, 0
    for seed in range(40):
        z, _ = first_order(np.random.default_rng(100 + seed), 0.3, equation=True)
        ze, zv = z.split(0.5)
        right = resid(arx(ze, 1, 1, 1), zv)
        false_alarms += not (right.white and right.independent)
        wrong = resid(arx(ze, 1, 1, 2), zv)  # the wrong delay
        wrong_ones += not wrong.independent
    assert false_alarms <= 3 and wrong_ones == 40


def dryer() -> IdData:
    table = np.loadtxt(REFERENCE / "dryer.dat")
    return IdData(table[:, [1]], table[:, [0]], 0.08, ("y",), ("u",))


def test_the_textbook_dryer_models_get_the_verdicts_their_fits_earn() -> None:
    plan = Plan(
        models=(
            ModelRequest("arx", {"na": 4, "nb": 4, "nk": 3}),
            ModelRequest("arx", {"na": 1, "nb": 1, "nk": 1}),
        ),
        arx_search=(range(1, 4), range(1, 4), range(1, 4)),
    )
    result = run(dryer(), plan)
    good, poor = result.models
    assert good.level == "good", good.verdicts
    assert poor.level == "poor"
    topics = {v.topic: v for v in poor.verdicts}
    assert topics["fit"].level == "poor" and topics["residuals"].level == "poor"
    assert all(v.advice for v in poor.verdicts if v.level != "good")
    data = {v.topic: v for v in result.verdicts}
    assert data["feedback"].level == "good" and data["delay"].finding.startswith("delay 3")
    # the search's best [3 3 3] is at the top of a 1 … 3 range: no answer
    assert data["order_search"].level == "caution" and "top of its range" in (
        data["order_search"].finding
    )


def test_an_unstable_model_an_absurd_fit_and_an_integrator_without_its_means() -> None:
    rng = np.random.default_rng(4)
    u = prbs(rng)
    y = np.cumsum(np.r_[0.0, u[:-1]]) * 0.01 + 0.001 * rng.standard_normal(N)  # integrates
    z = IdData(y[:, None], u[:, None], 0.01, ("θ",), ("u",))
    request = ModelRequest("arx", {"na": 1, "nb": 1, "nk": 1})
    means = run(z, Plan(models=(request,), correlation=False, spectral=False)).models[0]
    assert "integrator" in {v.topic for v in means.verdicts}
    kept = run(z, Plan(models=(request,), detrend="none", correlation=False, spectral=False))
    assert "integrator" not in {v.topic for v in kept.models[0].verdicts}
    assert kept.models[0].level == "good", kept.models[0].verdicts
    # noise alone as the output: nothing to fit, and the verdict explains what it prints
    junk = IdData(rng.standard_normal((N, 1)), u[:, None], 0.01, ("y",), ("u",))
    high = ModelRequest("arx", {"na": 8, "nb": 8, "nk": 1})
    model = run(junk, Plan(models=(high,), correlation=False, spectral=False)).models[0]
    assert model.level == "poor"
    assert worst(model.verdicts) == "poor"


def link_physics() -> Physics:
    p = get_plant("flexible_link")
    A, B, C, D = (np.asarray(m, dtype=float) for m in (p.A, p.B, p.C, p.D))
    return Physics(A, B, C[:1], D[:1])


def discrete(physics: Physics, Ts: float, gain: float = 1.0) -> LinearModel:
    """The physics held by a zero-order hold (python-control), as a model."""
    d = ct.c2d(ct.ss(physics.A, physics.B, physics.C, physics.D), Ts)
    n = d.nstates
    return LinearModel(d.A, d.B * gain, d.C, d.D, np.zeros((n, 1)), Ts, np.zeros((1, 1)))


def test_the_physics_verdict_measures_the_gap_as_python_control_does() -> None:
    physics = link_physics()
    # θ/u's zeros, ±18.85j (the antiresonance), as python-control finds them
    want = ct.ss(physics.A, physics.B, physics.C, physics.D).zeros()
    assert np.sort_complex(_zeros(physics, 0)) == pytest.approx(np.sort_complex(want), rel=1e-9)
    same = discrete(physics, 0.01)
    held = replace(physics, hold=0.01)  # the input held for the model's sample time
    assert physics_gap(same, physics)[1] > 10  # without the hold's half-sample lag: 18°
    db, deg, lo, hi = physics_gap(same, held)
    assert db < 0.05 and deg < 1.0  # a ZOH model of the physics is the physics at 10 ms
    assert lo == pytest.approx(22.19 / 10, rel=1e-3) and hi == pytest.approx(math.pi / 0.01 / 5)
    assert on_physics(same, held, "θ").level == "good"
    doubled = discrete(physics, 0.01, gain=2.0)  # 6.02 dB everywhere
    db, deg, _, _ = physics_gap(doubled, held)
    assert db == pytest.approx(20 * math.log10(2), abs=0.05) and deg < 1.0
    assert on_physics(doubled, held, "θ").level == "poor"
    rig = replace(held, nominal=True)  # a real rig is not its textbook: a caution
    said = on_physics(doubled, rig, "θ")
    assert said.level == "caution" and "nominal" in said.finding


def closed_loop_armax(seed: int) -> IdData:
    """y = 0.5 q⁻¹/(1 − 0.8 q⁻¹) u + (1 + 0.7 q⁻¹)/(1 − 0.8 q⁻¹) e — an ARMAX plant with
    coloured noise — under u = r − 0.6 y, r a PRBS."""
    rng = np.random.default_rng(seed)
    r, e = prbs(rng, hold=3), 0.5 * rng.standard_normal(N)
    y, u = np.zeros(N), np.zeros(N)
    for t in range(N):
        if t:
            y[t] = 0.8 * y[t - 1] + 0.5 * u[t - 1] + e[t] + 0.7 * e[t - 1]
        u[t] = r[t] - 0.6 * y[t]
    return IdData(y[:, None], u[:, None], 0.01, ("y",), ("u",))


def test_in_closed_loop_the_direct_pem_is_unbiased_where_arx_is_not() -> None:
    """The direct prediction-error method with the right noise model (ARMAX) is
    consistent on closed-loop data; ARX, whose noise model is wrong, is biased: the
    feedback verdict's advice. Over 20 seeds: ARMAX's a₁ and b₁ within 3 standard errors
    of their mean's truth, ARX's a₁ more than 10 away."""
    armax_ab, arx_ab = [], []
    for seed in range(20):
        z = closed_loop_armax(seed)
        assert feedback(z) > FEEDBACK_SHARE  # the data say they were recorded in closed loop
        p = armax(z, 1, 1, 1, 1).parameters
        q = arx(z, 1, 1, 1).parameters
        assert isinstance(p, ArmaxParameters) and isinstance(q, ArxParameters)
        armax_ab.append([p.A[1], p.B[1]])
        arx_ab.append([q.A[1], q.B[1]])
    truth = np.array([-0.8, 0.5])
    for estimates, unbiased in ((np.array(armax_ab), True), (np.array(arx_ab), False)):
        err = estimates.mean(axis=0) - truth
        standard = estimates.std(axis=0, ddof=1) / math.sqrt(len(estimates))
        if unbiased:
            assert np.all(np.abs(err) < 3 * standard), (err, standard)
        else:
            assert abs(err[0]) > 10 * standard[0], (err, standard)


def test_the_datas_verdicts_read_a_bounded_window_of_a_long_record(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Two million samples of lagged regressors would take gigabytes: the regressions
    behind the verdicts read the first ADVICE_ROWS samples (here 2,000 of 4,000: an
    open-loop half, then a closed-loop half that is not read)."""
    import elab.ident.advice as advice

    rng = np.random.default_rng(5)
    open_loop, _ = first_order(rng, 0.2)
    closed, _ = first_order(rng, 0.2, gain=1.5)
    both = IdData(np.vstack([open_loop.y, closed.y]), np.vstack([open_loop.u, closed.u]), 0.01)
    assert feedback(both) > FEEDBACK_SHARE
    monkeypatch.setattr(advice, "ADVICE_ROWS", N)
    assert feedback(both) == feedback(open_loop) < FEEDBACK_SHARE
    assert snr_db(both) == snr_db(open_loop)


@pytest.mark.parametrize(
    ("poles", "level"),
    [
        ([1.0052, 0.99, 0.5], "good"),  # the plant's unstable mode, kept
        ([1.004, 0.99], "good"),  # near it (more than half its margin outside)
        ([1.00001, 0.99], "poor"),  # an integrator a hair outside: the mode is missing
        ([0.999, 0.5], "poor"),  # stable: the mode reflected or lost
    ],
)
def test_an_unstable_plants_model_must_be_unstable_like_it(poles: list[float], level: str) -> None:
    """With the plant's unstable pole at |z| = 1.0052 (the pendulum's at 1 kHz), a model is
    right to be unstable like it and wrong to be stable or barely outside the unit circle;
    its simulated fit is a caution whatever its value, since a right model's simulation
    grows with the mode."""
    from elab.ident.modeladvice import on_model

    verdicts = on_model(
        np.array(poles, dtype=complex), -1e6, "estimated", None, "none", False, 1.0052
    )
    said = {v.topic: v for v in verdicts}
    assert said["stability"].level == level, said["stability"]
    assert said["fit"].level == "caution" and "below −100 %" in said["fit"].finding
    # a file's model (no physics): its fit judges it as ever
    plain = on_model(np.array(poles, dtype=complex), 95.0, "zero", None, "none", False)
    assert {v.topic: v for v in plain}["fit"].level == "good"
