"""Signals and sensor noise: defining properties."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from elab.errors import InvalidInput
from elab.sim import PRBS, Chirp, Sine, Square, Step, UserSamples, make_signal
from elab.sim.noise import BLOCK, sensor_noise


@pytest.mark.parametrize("order", [3, 7, 10, 15])
def test_prbs_is_a_maximum_length_sequence(order: int) -> None:
    s = PRBS(1.0, order=order)
    period = 2**order - 1
    v = s.sample(0, 2 * period, 1e-3)
    assert_array_equal(v[:period], v[period:])  # periodic with 2^n − 1
    assert set(np.unique(v)) == {-1.0, 1.0}
    assert v[:period].sum() == 1.0  # an m-sequence has one more 1 than 0 per period
    # two-valued autocorrelation of an m-sequence: −1/N off the zero lag
    c = np.array([np.dot(v[:period], np.roll(v[:period], k)) for k in range(1, min(20, period))])
    assert_allclose(c, -1.0)


def test_prbs_band_holds_each_level() -> None:
    v = PRBS(2.0, order=5, band=0.25, offset=1.0).sample(0, 200, 0.01)
    assert set(np.unique(v)) == {-1.0, 3.0}
    assert np.all(v.reshape(-1, 4) == v.reshape(-1, 4)[:, :1])  # held 1/band = 4 samples


@pytest.mark.parametrize("band", [0.0, 9.99e-7, 1e-300, 5e-324, 1.0000001])
def test_prbs_band_outside_its_range_is_refused_by_name(band: float) -> None:
    """A band of 1e-300 held each level 10³⁰⁰ samples, past what an index can count."""
    with pytest.raises(InvalidInput, match=r"signal\.band.*1e-06"):
        PRBS(1.0, band=band)


def test_prbs_at_its_narrowest_band_holds_a_level_a_million_samples() -> None:
    v = PRBS(1.0, order=3, band=1e-6).sample(3_600_000 - 5, 10, 1e-3)
    assert_array_equal(v, np.full(10, v[0]))  # sample 3.6 M is still in the 4th level


def test_square_has_its_period_and_levels() -> None:
    v = Square(0.5, period=0.1, offset=0.2).sample(0, 1000, 1e-3)
    assert_allclose(v[:50], 0.7)
    assert_allclose(v[50:100], -0.3)
    assert_array_equal(v[:100], v[900:])


def test_square_phase_does_not_drift_over_an_hour() -> None:
    v = Square(1.0, period=4.0).sample(3_600_000 - 2, 4, 1e-3)
    assert_allclose(v, [-1, -1, 1, 1])  # t = 3600 s is a whole number of periods


def test_signals_depend_only_on_the_sample_index() -> None:
    for sig in (
        Step(1.0, t0=0.5),
        Sine(1.0, 3.0, 0.2),
        Chirp(1.0, 0.1, 10.0, 2.0),
        PRBS(1.0, 8, 0.5),
        UserSamples((1.0, 2.0, 3.0)),
        Square(1.0, 0.3),
    ):
        whole = sig.sample(0, 3000, 1e-3)
        assert_array_equal(
            np.concatenate([sig.sample(0, 1234, 1e-3), sig.sample(1234, 1766, 1e-3)]), whole
        )


def test_user_samples_hold_their_last_value() -> None:
    assert_array_equal(UserSamples((1.0, 2.0)).sample(0, 4, 0.1), [1, 2, 2, 2])


def test_chirp_sweeps_its_band() -> None:
    v = Chirp(1.0, 1.0, 20.0, sweep=10.0).sample(0, 10_000, 1e-3)
    zero_crossings_first, zero_crossings_last = (
        np.sum(np.diff(np.sign(v[a : a + 1000])) != 0) for a in (0, 9000)
    )
    assert zero_crossings_first < 6 < 30 < zero_crossings_last


@pytest.mark.parametrize(
    ("kind", "params", "field"),
    [
        ("triangle", {}, "signal.kind"),
        ("square", {"amplitude": 1.0, "period": 0.0}, "signal.period"),
        ("square", {"amplitude": float("nan"), "period": 1.0}, "signal.amplitude"),
        ("sine", {"amplitude": 1.0, "frequency": -2.0}, "signal.frequency"),
        ("prbs", {"amplitude": 1.0, "order": 40}, "signal.order"),
        ("prbs", {"amplitude": 1.0, "band": 1.5}, "signal.band"),
        ("step", {"amplitude": 1.0, "colour": 3.0}, "signal.colour"),
        ("square", {"amplitude": 1.0}, "signal.period"),
        ("samples", {"values": (1.0, float("inf"))}, "signal.values"),
    ],
)
def test_bad_signal_names_the_field(kind: str, params: dict[str, float], field: str) -> None:
    with pytest.raises(InvalidInput) as err:
        make_signal(kind, **params)
    assert err.value.field == field
    assert field in str(err.value)


def test_noise_is_chunk_invariant_across_block_edges() -> None:
    std = np.array([1.0, 0.5])
    whole = sensor_noise(5, 100, 3 * BLOCK, std)
    parts = [
        sensor_noise(5, 100 + a, b - a, std)
        for a, b in [(0, 1), (1, BLOCK - 50), (BLOCK - 50, BLOCK + 7), (BLOCK + 7, 3 * BLOCK)]
    ]
    assert_array_equal(np.concatenate(parts), whole)
    assert_allclose(whole.std(axis=0), std, rtol=0.05)
