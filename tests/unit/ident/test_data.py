"""Identification data sets and the innovations model every estimator returns."""

from __future__ import annotations

from pathlib import Path

import control as ct
import numpy as np
import pytest
from numpy.testing import assert_allclose

from elab.errors import InvalidInput
from elab.ident import IdData, iddata, require_exciting
from elab.ident.models import LinearModel

DRYER = Path(__file__).resolve().parents[2] / "reference" / "ident" / "dryer.dat"


def test_the_dryer_data_split_and_detrended_as_matlab() -> None:
    raw = np.loadtxt(DRYER)
    z = iddata(
        raw[:, 1],
        raw[:, 0],
        0.08,
        output_names=("temperature",),
        input_names=("heater",),
        output_units=("V",),
        input_units=("V",),
    )
    assert (z.N, z.ny, z.nu) == (1000, 1, 1)
    ze, zr = z.split(500)
    assert (ze.N, zr.N, zr.k0) == (500, 500, 500)
    assert_allclose(zr.t[0], 40.0)
    ze = ze.detrend()
    assert_allclose(ze.y.mean(), 0, atol=1e-12)
    assert_allclose(ze.y + raw[:500, 1:2].mean(), raw[:500, 1:2])  # only the mean removed
    assert ze.trend == "mean" and ze.output_names == ("temperature",)


def test_linear_detrend_removes_a_ramp_exactly() -> None:
    t = np.arange(200.0)
    z = iddata(3 + 0.5 * t + np.sin(t), 1 - 0.1 * t + np.cos(t), 1.0).detrend("linear")
    fit = np.polyfit(t, z.y[:, 0], 1)
    assert_allclose(fit, [0, 0], atol=1e-2)  # what is left has no trend


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"y": [1, 2, np.nan], "u": [1, 2, 3], "Ts": 0.1}, "y[2, 0]"),
        ({"y": [1, 2, 3], "u": [1, np.inf, 3], "Ts": 0.1}, "u[1, 0]"),
        ({"y": [1, 2, 3], "u": [1, 2], "Ts": 0.1}, "u"),
        ({"y": [1], "u": [1], "Ts": 0.1}, "y"),
        ({"y": [1, 2, 3], "u": [1, 2, 3], "Ts": 0.0}, "Ts"),
        ({"y": [1, 2, 3], "u": [1, 2, 3], "Ts": float("nan")}, "Ts"),
        ({"y": "abc", "u": [1, 2, 3], "Ts": 0.1}, "y"),
    ],
)
def test_bad_data_names_the_field(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(InvalidInput) as err:
        iddata(**kwargs)  # type: ignore[arg-type]
    assert err.value.field == field


def test_split_and_slices_refuse_what_makes_no_sense() -> None:
    z = iddata(np.arange(10.0), np.arange(10.0), 1.0)
    for at in (0, 1, 9, 1.5, -0.2, True):
        with pytest.raises(InvalidInput):
            z.split(at)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput):
        z[::2]


def test_persistent_excitation() -> None:
    rng = np.random.default_rng(0)
    require_exciting(rng.standard_normal((500, 1)), 20)  # white noise: any order
    sine = np.sin(0.3 * np.arange(500))[:, None]
    require_exciting(sine, 2)  # a sine is exciting of order 2 exactly
    with pytest.raises(InvalidInput, match="not persistently exciting of order 3"):
        require_exciting(sine, 3)
    with pytest.raises(InvalidInput, match="constant"):
        require_exciting(np.full((500, 1), 2.0), 2)


def _model(seed: int = 1) -> tuple[LinearModel, IdData]:
    """A 2nd-order system in innovations form and data from it."""
    A = np.array([[1.5, -0.7], [1.0, 0.0]])
    B = np.array([[1.0], [0.0]])
    C = np.array([[0.5, 0.25]])
    K = np.array([[0.3], [0.1]])
    m = LinearModel(A, B, C, np.zeros((1, 1)), K, 0.1, np.eye(1) * 0.01)
    rng = np.random.default_rng(seed)
    N = 400
    u = rng.standard_normal(N)
    e = 0.1 * rng.standard_normal(N)
    x = np.zeros(2)
    y = np.empty(N)
    for t in range(N):
        y[t] = (C @ x)[0] + e[t]
        x = A @ x + B[:, 0] * u[t] + K[:, 0] * e[t]
    return m, iddata(y, u, 0.1)


def test_simulation_equals_python_control() -> None:
    m, z = _model()
    ref = ct.forced_response(m.to_control(), U=z.u[:, 0]).y[0]
    assert_allclose(m.simulate(z.u)[:, 0], ref, atol=1e-12)


def test_one_step_prediction_recovers_the_innovations() -> None:
    m, z = _model()
    rng = np.random.default_rng(1)
    rng.standard_normal(400)
    e = 0.1 * rng.standard_normal(400)
    # the data came from this very model from x0 = 0, so y − ŷ(t|t−1) = e exactly
    assert_allclose(z.y[:, 0] - m.predict(z, 1)[:, 0], e, atol=1e-12)


def test_k_step_prediction_between_one_step_and_simulation() -> None:
    m, z = _model()
    sim = m.simulate(z.u)[:, 0]
    errs = [np.linalg.norm(z.y[50:, 0] - m.predict(z, h)[50:, 0]) for h in (1, 2, 5, 40)]
    assert errs == sorted(errs)  # worse with the horizon
    assert_allclose(m.predict(z, 200)[250:, 0], sim[250:], atol=1e-9)  # far ahead: simulation
    # the 2-step predictor by hand: x(t|t−2) = A x̂(t−1|t−2) + B u(t−1)
    p1 = np.zeros((400, 2))
    x = np.zeros(2)
    for t in range(400):
        p1[t] = x
        x = m.A @ x + m.B[:, 0] * z.u[t, 0] + m.K[:, 0] * (z.y[t, 0] - m.C @ x)
    by_hand = (p1[:-1] @ m.A.T + z.u[:-1] @ m.B.T) @ m.C.T
    assert_allclose(m.predict(z, 2)[1:], by_hand, atol=1e-12)
    with pytest.raises(InvalidInput):
        m.predict(z, 0)
