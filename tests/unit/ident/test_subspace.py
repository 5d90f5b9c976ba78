"""Subspace identification (PO-MOESP) against the published hair-dryer results, known
systems (every plant's discretised model, lightly damped systems) and its own guarantees."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import control as ct
import numpy as np
import pytest
import scipy.signal
from numpy.testing import assert_allclose

from elab.errors import InvalidInput
from elab.ident import IdData, iddata
from elab.ident.assess import model_notes
from elab.ident.subspace import choose_order, decompose, n4sid
from elab.ident.validation import compare
from elab.laws import StateFeedback
from elab.plants import get_plant


def test_dryer_singular_values_and_fits(dryer: tuple[IdData, IdData]) -> None:
    ze, zr = dryer
    sub = decompose(ze, 16)
    # published (README), to their 3-4 significant digits
    assert_allclose(sub.singular_values[:5], [39.13, 9.925, 2.132, 1.081, 0.416], rtol=1.5e-3)
    assert compare(n4sid(ze, 4, sub=sub), zr).fit[0] >= 89  # published: 89.8 %
    assert compare(n4sid(ze, 3, sub=sub), zr).fit[0] >= 89  # published: 89.5 %
    choice = choose_order(sub, range(1, 11))
    # the singular values fall at most 4.7×, so the orders are cross-validated on the
    # record's last third: 6 wins (84.6 %, against 83.5 % for 4), and its validation fit
    # (89.73 %) is the best order's (4: 89.77 %) within 0.1 point ("order 3 or 4 suggested")
    assert "last third" in choice.reason, choice.reason
    best = max(compare(n4sid(ze, n, sub=sub), zr).fit[0] for n in range(1, 11))
    assert compare(n4sid(ze, choice.best, sub=sub), zr).fit[0] >= best - 0.5
    assert [r.order for r in choice.rows] == list(range(1, 11))
    assert choice.rows[0].loss > choice.rows[3].loss
    assert choice.rows[0].holdout < choice.rows[3].holdout


def _closed_loops() -> list[tuple[str, ct.StateSpace]]:
    """Every plant, discretised at 10 ms, in closed loop with its predefined state feedback
    where it has one (u = −K x + v; the open-loop pendulum would diverge), else open loop."""
    out = []
    for pid in ("flexible_link", "double_pendulum", "belt_conveyor"):
        p = get_plant(pid)
        A, B, C = (np.asarray(m, dtype=float) for m in (p.A, p.B, p.C))
        if isinstance(p.predefined, StateFeedback):
            A = A - B @ np.atleast_2d(p.predefined.K)
        out.append((pid, ct.c2d(ct.ss(A, B, C, np.zeros((C.shape[0], B.shape[1]))), 0.01)))
    return out


@pytest.mark.parametrize(
    ("pid", "sys"), _closed_loops(), ids=lambda v: v if isinstance(v, str) else ""
)
def test_noise_free_subspace_recovers_every_plants_poles(pid: str, sys: ct.StateSpace) -> None:
    u = np.random.default_rng(2).standard_normal(3000)
    _, y = ct.forced_response(sys, U=u)
    z = iddata(np.atleast_2d(y).T, u, 0.01)
    m = n4sid(z, sys.nstates, horizon=sys.nstates + 4, stable=False)
    assert_allclose(np.sort_complex(m.poles), np.sort_complex(sys.poles()), atol=1e-6)
    assert compare(m, z).fit.min() > 99.9999


def test_lightly_damped_system_validates_above_80_percent() -> None:
    # two resonances, |z| = 0.997 and 0.995, 20 dB output noise
    poles = [0.997 * np.exp(1j * 0.3), 0.995 * np.exp(1j * 0.9)]
    a = np.real(np.poly(poles + [np.conj(p) for p in poles]))
    b = np.array([0, 0.02, -0.01, 0.015, 0.005])
    rng = np.random.default_rng(4)
    u = rng.standard_normal(6000)
    clean = scipy.signal.lfilter(b, a, u)
    y = clean + clean.std() / 10 * rng.standard_normal(u.shape[0])
    ze, zv = iddata(y, u, 1.0).split(0.5)
    m = n4sid(ze, 4, horizon=20)
    assert np.all(np.abs(m.poles) >= 0.99)
    assert compare(m, zv, x0="estimate").fit[0] >= 80
    assert_allclose(np.sort(np.abs(m.poles)), [0.995, 0.995, 0.997, 0.997], atol=2e-3)


def test_unstable_estimates_are_kept_by_default_and_reflected_on_request() -> None:
    """By default A is kept as estimated (issue 16: the zero-padded stabilisation pulled
    every pole inward); ``stable=True`` reflects the pole outside the unit circle to
    1/|z| and keeps the other one where it was."""
    a = np.real(np.poly([1.004, 0.5]))
    u = np.random.default_rng(6).standard_normal(400)
    z = iddata(scipy.signal.lfilter([0, 1, 0.3], a, u), u, 1.0)
    free = n4sid(z, 2, horizon=6)
    assert np.max(np.abs(free.poles)) == pytest.approx(1.004, abs=1e-6)
    assert not free.parameters.stabilised and free.parameters.reflected == ()
    tamed = n4sid(z, 2, horizon=6, stable=True)
    assert tamed.parameters.stabilised
    [(before, after)] = tamed.parameters.reflected
    assert before == pytest.approx(1.004, abs=1e-6) and after == pytest.approx(1 / before)
    assert_allclose(
        np.sort(np.abs(tamed.poles)), np.sort([1 / before, np.min(np.abs(free.poles))]), rtol=1e-9
    )


def test_kalman_gain_gives_a_better_one_step_predictor(dryer: tuple[IdData, IdData]) -> None:
    ze, zr = dryer
    m = n4sid(ze, 4, horizon=16)
    assert np.any(m.K != 0)
    assert np.max(np.abs(np.linalg.eigvals(m.A - m.K @ m.C))) < 1
    assert compare(m, zr, horizon=1).fit[0] > compare(m, zr).fit[0] + 2


def test_bad_requests_say_what_is_wrong(dryer: tuple[IdData, IdData]) -> None:
    ze, _ = dryer
    with pytest.raises(InvalidInput) as err:
        n4sid(ze, 4, horizon=1)
    assert err.value.field == "horizon"
    with pytest.raises(InvalidInput) as err:
        n4sid(ze, 16, horizon=16)
    assert err.value.field == "order" and "order < horizon" in str(err.value)
    with pytest.raises(InvalidInput, match="constant"):
        n4sid(iddata(np.arange(200.0), np.ones(200), 1.0), 2)
    with pytest.raises(InvalidInput) as err:
        n4sid(ze[:20], 2, horizon=8)
    assert err.value.field == "horizon"


def test_the_workflow_says_when_a_model_is_unstable_as_estimated() -> None:
    from elab.ident import workflow as wf

    a = np.real(np.poly([1.004, 0.5]))
    u = np.random.default_rng(6).standard_normal(800)
    z = iddata(scipy.signal.lfilter([0, 1, 0.3], a, u), u, 1.0)
    out = wf.run(
        z,
        wf.Plan(
            models=(wf.parse_model("n4sid:2,6"),), correlation=False, spectral=False, detrend="none"
        ),
    )
    assert any("n4sid 2 6: a pole outside the unit circle (|z| = 1.004" in n for n in out.notes)
    m = out.models[0].model
    assert m.parameters.kalman == "riccati"  # B and D from the R factor: a predictor exists
    assert np.max(np.abs(np.linalg.eigvals(m.A - m.K @ m.C))) < 1
    fits = out.models[0].fits
    assert fits.headline.x0 == "estimated" and "unstable" in fits.headline.why
    assert fits.headline_fit is fits.validation_simulation_x0
    # the fallback, when the Riccati equation has no stabilising solution, is said too
    said = model_notes("n4sid 2", replace(m, parameters=replace(m.parameters, kalman="none")))
    assert any("no Kalman gain" in n for n in said)


def test_a_gap_in_the_singular_values_decides_the_order() -> None:
    """Order 4 with little noise: the singular values fall far more than 100× after the
    fourth, which decides whatever MDL says (issue 16: MDL picked 10 and 6)."""
    rng = np.random.default_rng(4)
    u = rng.standard_normal(2000)
    y = ct.forced_response(
        ct.tf([0.2, 0.1], [1, -1.2, 0.5], 1) * ct.tf([1.0], [1, -0.6, 0.25], 1), np.arange(2000), u
    ).outputs + 1e-6 * rng.standard_normal(2000)
    z = iddata(y, u, 1.0)
    sub = decompose(z, 16)
    choice = choose_order(sub, range(1, 11))
    why = choice.reason
    assert choice.best == 4 and "fall" in why and "after order 4" in why, why
    assert n4sid(z).nx == 4


def _lightly_damped(seed: int) -> tuple[IdData, IdData]:
    """Two resonances at |z| = 0.998 and 0.995 (a flexible structure), white input, 5 %
    output noise; 600 samples to estimate, 600 to validate."""
    poles = [0.998 * np.exp(0.05j), 0.995 * np.exp(0.3j)]
    a = np.real(np.poly(poles + [np.conj(p) for p in poles]))
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(1200)
    y = scipy.signal.lfilter([0, 0.02, -0.01, 0.015], a, u)
    y = y + 0.05 * np.std(y) * rng.standard_normal(y.size)
    z = iddata(y, u, 1.0)
    return z[:600], z[600:]


@pytest.mark.parametrize("seed", range(4))
def test_an_unstable_estimate_of_a_lightly_damped_plant_gives_a_good_default(seed: int) -> None:
    """Issue 16: the shift-invariance estimate crosses the unit circle at some orders
    (|z| 1.0003 … 1.04 here); the default model at each such order fits the validation
    record (from its estimated initial state: the headline for modes this slow) within 1
    point of the better of the estimate as it is and its reflection. (The zero-padded
    stabilisation, once the default, fitted 13 % where the estimate fitted 96.7 %.)"""
    ze, zv = _lightly_damped(seed)
    sub = decompose(ze, 20)
    crossed = 0
    for n in range(2, 11):
        kept = n4sid(ze, n, sub=sub, stable=False)
        if np.max(np.abs(kept.poles)) <= 1:
            continue
        crossed += 1
        default = n4sid(ze, n, sub=sub)
        reflected = n4sid(ze, n, sub=sub, stable=True)
        mine, as_is, refl = (
            compare(m, zv, x0="estimate").fit[0] for m in (default, kept, reflected)
        )
        assert mine >= max(as_is, refl) - 1.0, (n, mine, as_is, refl)
        p = default.parameters
        assert p.choice.fit_reflected != p.choice.fit_as_estimated
        chosen_reflected = p.choice.fit_reflected > p.choice.fit_as_estimated
        assert p.stabilised == chosen_reflected
    assert crossed >= 1 or seed in (2,)  # seed 2's estimates stay inside at every order


@pytest.mark.parametrize(
    ("name", "columns", "nest", "s"),
    [("dryer", (1, 0), 500, 16), ("robot_arm", (1, 0), 512, 20), ("exchanger", (2, 1), 2000, 20)],
)
def test_every_order_is_no_worse_than_the_estimate_as_it_is(
    name: str, columns: tuple[int, int], nest: int, s: int
) -> None:
    """Orders 1–10 on the public data sets: the default model validates at least as well
    as the unstabilised estimate, from a zero and from the estimated initial state (the
    unstable estimates at orders 6 and 10 of the dryer, 10 of the robot arm and 6, 8, 10
    of the heat exchanger are reflected, and fit better for it)."""
    raw = np.loadtxt(Path(__file__).resolve().parents[2] / "reference" / "ident" / f"{name}.dat")
    y, u = raw[:, columns[0]], raw[:, columns[1]]
    ze = iddata(y[:nest] - y[:nest].mean(), u[:nest] - u[:nest].mean(), 1.0)
    zv = iddata(y[nest:] - y[nest:].mean(), u[nest:] - u[nest:].mean(), 1.0)
    sub = decompose(ze, s)
    for n in range(1, 11):
        default, kept = n4sid(ze, n, sub=sub), n4sid(ze, n, sub=sub, stable=False)
        for x0 in ("zero", "estimate"):
            mine = compare(default, zv, x0=x0).fit[0]
            as_is = compare(kept, zv, x0=x0).fit[0]
            assert mine >= as_is - 0.05 or not np.isfinite(as_is), (n, x0, mine, as_is)


def test_the_headline_fit_is_the_one_that_means_something(dryer: tuple[IdData, IdData]) -> None:
    """From a zero state when every mode decays within the validation record (the hair
    dryer, the published convention); from the estimated state for an integrator (the
    zero-state fit of an integrating plant's model measures where the record starts)."""
    from elab.ident import workflow as wf

    ze, zv = dryer
    plan = wf.Plan(models=(wf.parse_model("arx:2,2,3"),), correlation=False, spectral=False)
    fit = wf.run(ze, plan, validation=zv).models[0].fits
    assert fit.headline.x0 == "zero" and fit.headline_fit is fit.validation_simulation
    rng = np.random.default_rng(3)
    u = np.sign(rng.standard_normal(1000))
    y = scipy.signal.lfilter([0, 0.1], [1, -1], u) + 0.01 * rng.standard_normal(1000)
    out = wf.run(
        iddata(y, u, 0.1), replace(plan, models=(wf.parse_model("arx:1,1,1"),), detrend="none")
    )
    fit = out.models[0].fits
    assert fit.headline.x0 == "estimated" and fit.headline_fit is fit.validation_simulation_x0
    assert "more than a fifth of the 500-sample record" in fit.headline.why
    assert fit.headline_fit.fit[0] > 90 > 0 > fit.validation_simulation.fit[0]  # 93.8 %, −151 %


def test_an_unstable_candidate_whose_error_squares_past_the_largest_float_has_infinite_loss() -> (
    None
):
    """A candidate A with a pole at 1.3 simulates 1,400 samples to about 1e160: finite, but
    its square overflows. Its loss is infinite without a warning (the suite turns warnings
    into errors; seen on a two-stage record's order choice)."""
    from elab.ident import subspace

    rng = np.random.default_rng(0)
    z = iddata(rng.standard_normal(1400), rng.standard_normal(1400), 1.0)
    sub = subspace.decompose(z, 8)
    fitted = subspace._model(sub, np.array([[1.3]]), np.array([[1.0]]), (), "subspace")
    assert fitted.loss == np.inf


def test_the_modes_powers_equal_numpys_complex_power() -> None:
    """The fitted initial state's modes λᵗ (real powers with their sign, and |λ|ᵗ e^{itθ})
    equal numpy's complex power within 1e-11 (relative) wherever it is finite, for
    decaying, oscillating, negative, zero, unit and growing λ."""
    from elab.ident.models import _powers

    lam = np.array([0.95, -0.7, 0.0, 0.8 + 0.3j, 0.8 - 0.3j, 1.0, -1.0, 1.02, -0.3j])
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        got, want = _powers(lam, 3000), lam[None, :] ** np.arange(3000)[:, None]
    finite = np.isfinite(want)
    assert np.array_equal(np.isfinite(got), finite)
    scale = np.maximum(np.abs(want[finite]), 1e-300)
    assert np.max(np.abs(got[finite] - want[finite]) / scale) < 1e-11
    assert np.all(got[:, [0, 1, 2, 5, 6, 7]].imag == 0)  # real λ: real powers, exactly


def test_the_modal_fit_leaves_out_only_rows_where_every_mode_has_decayed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A stable model's modal initial-state fit reads its first rows only (the rest are
    zeros of the fit): the state it returns is the one every row gives, within 1e-9."""
    from elab.ident import models

    rng = np.random.default_rng(3)
    A = np.diag([0.9, 0.5, -0.7, 0.95])
    C = np.ones((1, 4))
    x_true = np.array([1.0, -2.0, 0.5, 3.0])
    t = np.arange(10_000)
    free = ((np.diag(A)[None, :] ** t[:, None]) @ x_true)[:, None]
    free += 1e-3 * rng.standard_normal(free.shape)
    short = models._modal_refit(A, C, free, np.zeros(4))
    monkeypatch.setattr(models, "MODE_FLOOR", 1e-300)  # every row
    every = models._modal_refit(A, C, free, np.zeros(4))
    np.testing.assert_allclose(short, every, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(short, x_true, atol=0.05)
