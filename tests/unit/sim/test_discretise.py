"""The stepping loop's discretisations without python-control (issue 28: ``elab simulate``
imports neither it nor matplotlib nor scipy.signal) against python-control's ``c2d``: the
plant's zero-order hold and every law's Tustin controller are the same numbers, bit for
bit, on every plant and on random systems (tests/unit/test_cli_imports.py: the imports)."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from elab.design.realise import realise
from elab.laws import PID, ControlLaw, LTIController, StateFeedback
from elab.lti import tustin, zoh
from elab.plants import PLANTS
from elab.sim.controllers import discretise


def _same(got: np.ndarray, want: object) -> None:
    want = np.asarray(want, dtype=np.float64)
    assert got.shape == want.shape and np.array_equal(got, want), (got, want)


def _system(seed: int, n: int, m: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    scale = 10.0 ** rng.uniform(-2, 3)
    return (
        scale * rng.standard_normal((n, n)),
        rng.standard_normal((n, m)),
        rng.standard_normal((1, n)),
        rng.standard_normal((1, m)),
    )


@settings(max_examples=80, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 8),
    m=st.integers(1, 4),
    Ts=st.sampled_from([1e-4, 1e-3, 0.01, 0.1]),
)
def test_zoh_and_tustin_are_python_controls_c2d(seed: int, n: int, m: int, Ts: float) -> None:
    A, B, C, D = _system(seed, n, m)
    want = ct.c2d(ct.ss(A, B, C, D), Ts, method="zoh")
    Ad, Bd = zoh(A, B, Ts)
    _same(Ad, want.A)
    _same(Bd, want.B)
    want = ct.c2d(ct.ss(A, B, C, D), Ts, method="tustin")
    for got, w in zip(tustin(A, B, C, D, Ts), (want.A, want.B, want.C, want.D), strict=True):
        _same(got, w)


def _laws(plant_id: str) -> list[ControlLaw]:
    plant = PLANTS[plant_id]
    laws: list[ControlLaw] = [plant.predefined, PID(Kp=2.0, Ki=0.5, Kd=0.1)]
    if isinstance(plant.predefined, StateFeedback):
        poles = tuple(-20.0 - 3.0 * k for k in range(plant.nx))
        laws.append(StateFeedback(K=plant.predefined.K, estimate="observer", observer_poles=poles))
    laws.append(LTIController(num=(1.0, 2.0), den=(1.0, 30.0)))
    return laws


@pytest.mark.parametrize("plant_id", sorted(PLANTS))
def test_every_laws_controller_is_python_controls_tustin(plant_id: str) -> None:
    plant = PLANTS[plant_id]
    for law in _laws(plant_id):
        real = realise(plant, law, all_pid_states=True)
        got = discretise(law, plant, plant.Ts)
        n = real.A.shape[0]
        if n == 0:  # a static law: its gains as they are
            _same(got.Dc, np.asarray(real.ss().D)[0])
            assert got.Ac.shape == (0, 0) and got.Cc.shape == (0,)
            continue
        want = ct.c2d(real.ss(), plant.Ts, method="tustin")
        _same(got.Ac, np.asarray(want.A).reshape(n, n))
        _same(got.Bc, np.asarray(want.B).reshape(n, -1))
        _same(got.Cc, np.asarray(want.C).reshape(-1)[:n])
        _same(got.Dc, np.asarray(want.D)[0])


@pytest.mark.parametrize("plant_id", sorted(PLANTS))
def test_the_plants_zero_order_hold_is_python_controls(plant_id: str) -> None:
    plant = PLANTS[plant_id]
    want = ct.c2d(ct.ss(plant.A, plant.B, plant.C, plant.D), plant.Ts, method="zoh")
    Ad, Bd = zoh(plant.A, plant.B, plant.Ts)
    _same(Ad, want.A)
    _same(Bd, want.B)
