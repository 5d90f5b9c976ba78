"""ARX estimation and order search, correlation analysis and model validation (fit %,
residuals) against the published hair-dryer results and known systems."""

from __future__ import annotations

import warnings

import control as ct
import numpy as np
import pytest
import scipy.signal
from numpy.testing import assert_allclose

from elab.errors import InvalidInput
from elab.ident import IdData, iddata
from elab.ident.nonparametric import cra, spa
from elab.ident.parameters import ArxParameters
from elab.ident.polynomial import arx, arxstruc, from_polynomials, selstruc, struc
from elab.ident.validation import compare, fit_percent, resid
from elab.laws import StateFeedback
from elab.plants import get_plant


def test_dryer_delay_is_three(dryer: tuple[IdData, IdData]) -> None:
    ze, zr = dryer
    assert selstruc(arxstruc(ze, zr, struc([2], [2], range(1, 11))), 0)[2] == 3


def test_dryer_best_structure_and_its_loss(dryer: tuple[IdData, IdData]) -> None:
    ze, zr = dryer
    V = arxstruc(ze, zr, struc(range(1, 11), range(1, 11), [3]))
    assert selstruc(V, 0) == (4, 4, 3)
    assert V[:, 3].min() == pytest.approx(0.0022583, rel=0.01)  # published (README)
    assert V[:, 3].min() == pytest.approx(0.0022583315, rel=1e-6)  # and to its digits


def test_dryer_arx_223_coefficients_and_fit(dryer: tuple[IdData, IdData]) -> None:
    ze, zr = dryer
    m = arx(ze, 2, 2, 3)
    assert_allclose(m.parameters.A, [1, -1.2765, 0.3967], atol=5e-4)
    # B against an independent least squares written out here
    y, u = ze.y[:, 0], ze.u[:, 0]
    t = np.arange(4, 500)
    Phi = np.column_stack([-y[t - 1], -y[t - 2], u[t - 3], u[t - 4]])
    theta = np.linalg.lstsq(Phi, y[t], rcond=None)[0]
    assert_allclose(m.parameters.B, [0, 0, 0, *theta[2:]], atol=1e-12)
    assert compare(m, zr).fit[0] == pytest.approx(89.55, abs=0.3)
    assert compare(arx(ze, 4, 4, 3), zr).fit[0] == pytest.approx(89.91, abs=0.3)


def test_polynomial_model_simulates_as_lfilter() -> None:
    a, b, c = np.array([1, -1.5, 0.7]), np.array([0, 0.5, 0.3]), np.array([1, 0.4])
    m = from_polynomials(a, b, c, 0.1, 1.0)
    u = np.random.default_rng(3).standard_normal(300)
    assert_allclose(m.simulate(u)[:, 0], scipy.signal.lfilter(b, a, u), atol=1e-12)


def _plant_polynomials(pid: str) -> tuple[np.ndarray, np.ndarray]:
    """A(q), B(q) from u to the first output of a plant discretised at 50 ms (zero-order
    hold), in closed loop with its predefined state feedback where it has one (u = −K x
    + v: the open-loop pendulum would diverge), minimal. At 50 ms the poles stand apart
    (at 10 ms the pendulum's cluster near z = 1 turns round-off in the coefficients into
    1e-6 in its roots, whatever estimated them)."""
    p = get_plant(pid)
    A, B, C = (np.asarray(m, dtype=float) for m in (p.A, p.B, p.C))
    if isinstance(p.predefined, StateFeedback):
        A = A - B @ np.atleast_2d(p.predefined.K)
    tf = ct.minreal(ct.tf(ct.ss(A, B, C[:1], np.zeros((1, 1)))), verbose=False)
    # scipy's c2d of a transfer function goes through state space and back: the leading
    # numerator terms, exactly 0 for a strictly proper plant held by a ZOH, come back as
    # round-off (1e-15 on one CPU, exactly 0 on another), and scipy warns about them
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scipy.signal.BadCoefficients)
        num, den = (np.ravel(x) for x in ct.tfdata(ct.c2d(tf, 0.05)))
    num = np.r_[np.zeros(len(den) - len(num)), num]
    num[np.abs(num) < 1e-9 * np.abs(num).max()] = 0.0
    return den / den[0], num / den[0]


@pytest.mark.parametrize("pid", ["flexible_link", "double_pendulum", "belt_conveyor"])
def test_noise_free_arx_recovers_every_plants_poles(pid: str) -> None:
    a, b = _plant_polynomials(pid)
    u = np.random.default_rng(1).standard_normal(3000)
    y = scipy.signal.lfilter(b, a, u)
    na = len(a) - 1
    m = arx(iddata(y, u, 0.05), na, na, 1)
    assert_allclose(np.sort_complex(m.poles), np.sort_complex(np.roots(a)), atol=1e-6)


def test_arx_is_unbiased_over_100_seeds_at_20_db() -> None:
    a, b = np.array([1, -1.2, 0.5]), np.array([0, 1.0, 0.5])
    rng = np.random.default_rng(7)
    N, runs = 400, 100
    u = rng.standard_normal(N)
    clean = scipy.signal.lfilter(b, a, u)
    sigma = clean.std() / 10  # 20 dB SNR
    est = []
    for _ in range(runs):  # ARX noise: e enters through 1/A, the structure arx assumes
        y = clean + scipy.signal.lfilter([1], a, sigma * rng.standard_normal(N))
        m = arx(iddata(y, u, 1.0), 2, 2, 1)
        est.append(np.r_[m.parameters.A[1:], m.parameters.B[1:]])
    est = np.array(est)
    se = est.std(axis=0, ddof=1) / np.sqrt(runs)
    assert np.all(np.abs(est.mean(axis=0) - np.r_[a[1:], b[1:]]) < 2.5 * se)


def test_fit_percent_and_initial_state(dryer: tuple[IdData, IdData]) -> None:
    y = np.array([[1.0], [2.0], [3.0]])
    assert fit_percent(y, y)[0] == 100
    assert fit_percent(y, np.full_like(y, 2.0))[0] == pytest.approx(0)
    ze, zr = dryer
    m = arx(ze, 2, 2, 3)
    assert compare(m, zr, x0="estimate").fit[0] > compare(m, zr).fit[0]
    assert compare(m, zr, horizon=1).fit[0] > compare(m, zr, horizon=5).fit[0]


def test_bad_requests_say_what_is_wrong(dryer: tuple[IdData, IdData]) -> None:
    ze, _ = dryer
    with pytest.raises(InvalidInput, match="constant"):
        arx(iddata(np.arange(50.0), np.ones(50), 1.0), 2, 2, 1)
    with pytest.raises(InvalidInput, match="more than"):
        arx(ze[:10], 4, 4, 3)
    with pytest.raises(InvalidInput) as err:
        arx(ze, -1, 2, 1)
    assert err.value.field == "na"
    with pytest.raises(InvalidInput, match="aic"):
        selstruc(arxstruc(ze, ze, struc([1], [1], [1])), "bic")  # type: ignore[arg-type]


def test_dryer_correlation_analysis_shows_the_delay(dryer: tuple[IdData, IdData]) -> None:
    ze, _ = dryer
    c = cra(ze, max_lag=20, k_sigma=3)
    band = 3 * c.sigma
    assert np.all(np.abs(c.impulse[:3]) <= band)  # lags 0..2 inside the band (README)
    assert c.delay == 3


def test_correlation_analysis_recovers_a_known_impulse_response() -> None:
    g = np.array([0, 0, 0.5, 0.8, 0.4, 0.1])
    rng = np.random.default_rng(5)
    u = scipy.signal.lfilter([1], [1, -0.5], rng.standard_normal(20_000))  # coloured input
    y = scipy.signal.lfilter(g, [1], u) + 0.05 * rng.standard_normal(u.shape[0])
    c = cra(iddata(y, u, 1.0), max_lag=10)
    assert_allclose(c.impulse[:6], g, atol=4 * c.sigma)
    assert np.all(np.abs(c.impulse[7:]) < 4 * c.sigma)
    assert c.delay == 2


def test_residuals_of_a_right_model_are_white_and_of_a_wrong_one_not() -> None:
    a, b = np.array([1, -1.2, 0.5]), np.array([0, 1.0, 0.5])
    # each of 25 lags has a 1 % false alarm, so about one seed in five shows a lag just
    # outside the bound even for the right model; this seed does not
    rng = np.random.default_rng(3)
    u = rng.standard_normal(3000)
    e = 0.3 * rng.standard_normal(3000)
    y = scipy.signal.lfilter(b, a, u) + scipy.signal.lfilter([1], a, e)
    z = iddata(y, u, 1.0)
    ze, zv = z.split(0.5)
    right = resid(arx(ze, 2, 2, 1), zv)
    assert right.white and right.independent
    wrong = resid(arx(ze, 1, 1, 1), zv)
    assert not wrong.white
    assert np.abs(wrong.autocorrelation[1:]).max() > 3 * right.bound
    assert right.bound == pytest.approx(2.58 / np.sqrt(1500))


def test_spectral_analysis_matches_a_known_frequency_response() -> None:
    a, b = np.array([1, -0.9]), np.array([0, 0.5])  # smooth low-pass: the window resolves it
    rng = np.random.default_rng(9)
    u = rng.standard_normal(100_000)
    y = scipy.signal.lfilter(b, a, u) + 0.1 * rng.standard_normal(u.shape[0])
    s = spa(iddata(y, u, 0.1), window=100)
    _, true = scipy.signal.freqz(b, a, worN=s.omega * 0.1)
    assert_allclose(s.G, true, rtol=0.1)
    assert s.window == 100 and len(s.omega) == 128
    assert s.omega[-1] == pytest.approx(np.pi / 0.1)
    # white noise of variance λ = 0.01 has the flat spectrum λ·Ts (MATLAB's scaling)
    assert_allclose(np.median(s.noise), 0.01 * 0.1, rtol=0.1)


def test_spectral_analysis_default_window_and_bad_input(dryer: tuple[IdData, IdData]) -> None:
    ze, _ = dryer
    assert spa(ze).window == 30  # min(N/10, 30)
    with pytest.raises(InvalidInput) as err:
        spa(ze, window=1)
    assert err.value.field == "window"
    with pytest.raises(InvalidInput, match="rad/s"):
        spa(ze, omega=np.array([100.0]))


def test_an_exact_fit_has_a_zero_loss_and_an_aic_of_minus_infinity() -> None:
    """An output of zeros is fitted exactly (loss 0): its AIC is −∞, as for several outputs,
    not a math domain error (the workflow names such an output before estimating; a
    direct ``arx`` call raised)."""
    u = np.sign(np.random.default_rng(1).standard_normal(200))
    m = arx(IdData(np.zeros((200, 1)), u[:, None], 0.01), 1, 1, 1)
    assert isinstance(m.parameters, ArxParameters)
    assert m.parameters.loss == 0.0 and m.parameters.aic == -np.inf
