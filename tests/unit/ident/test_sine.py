"""Sine analysis (frequency analysis by correlation) against scipy's freqz."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from elab.errors import InvalidInput
from elab.ident import IdData, iddata
from elab.ident.nonparametric import SineResponse, sine_response

B, A, TS = np.array([0, 0.5, 0.3]), np.array([1, -1.2, 0.5]), 0.1


def _experiment(
    f: float, N: int, noise: float = 0.0, offset: float = 0.0
) -> tuple[IdData, complex]:
    u = offset + np.sin(2 * np.pi * f * TS * np.arange(N))
    y = scipy.signal.lfilter(B, A, u) + noise * np.random.default_rng(2).standard_normal(N)
    _, g = scipy.signal.freqz(B, A, worN=[2 * np.pi * f * TS])
    return iddata(y, u, TS), complex(g[0])


def _G(r: SineResponse) -> complex:
    return complex(r.magnitude * np.exp(1j * np.radians(r.phase_deg)))


@pytest.mark.parametrize("f", [0.25, 0.5, 1.0, 2.5])  # 40, 20, 10, 4 samples per period
def test_gain_and_phase_equal_freqz(f: float) -> None:
    z, g = _experiment(f, 1000, offset=0.3)
    r = sine_response(z, f)
    assert abs(_G(r) - g) < 1e-3 * abs(g)
    assert r.magnitude == pytest.approx(abs(g), rel=1e-3)
    assert r.phase_deg == pytest.approx(np.degrees(np.angle(g)), abs=0.06)
    assert r.samples_used == round(r.periods_used / (f * TS))
    assert r.samples_used <= 750  # the first quarter is skipped
    assert r.omega == pytest.approx(2 * np.pi * f)


def test_a_period_of_a_fractional_number_of_samples() -> None:
    z, g = _experiment(0.37, 1000)  # 27.03 samples per period
    r = sine_response(z, 0.37)
    assert abs(_G(r) - g) < 1e-3 * abs(g)


def test_noise_is_averaged_out() -> None:
    z, g = _experiment(0.5, 4000, noise=0.3)
    assert abs(_G(sine_response(z, 0.5)) - g) < 0.02 * abs(g)


def test_transient_skip() -> None:
    z, g = _experiment(0.5, 400)
    r = sine_response(z, 0.5)
    assert (r.periods_used, r.samples_used) == (15, 300)  # 100 samples = 5 periods skipped
    r0 = sine_response(z, 0.5, periods_skip=0)
    assert (r0.periods_used, r0.samples_used) == (20, 400)
    assert abs(_G(r0) - g) > 1e-3 * abs(g)  # the start-up transient biases the estimate


def test_bad_requests() -> None:
    z, _ = _experiment(0.5, 400)
    for f in (0.0, -1.0, 5.0, 7.0, float("nan")):  # Nyquist is 5 Hz
        with pytest.raises(InvalidInput) as err:
            sine_response(z, f)
        assert err.value.field == "frequency_hz"
    with pytest.raises(InvalidInput, match="whole period"):
        sine_response(z[:30], 0.5)  # 20 samples per period: one skipped, 10 left
    with pytest.raises(InvalidInput, match="whole period"):
        sine_response(z, 0.5, periods_skip=20)
    with pytest.raises(InvalidInput) as err:
        sine_response(z, 0.5, periods_skip=-1)
    assert err.value.field == "periods_skip"
    with pytest.raises(InvalidInput) as err:
        sine_response(iddata(z.y, np.ones(400), TS), 0.5)
    assert err.value.field == "u"
