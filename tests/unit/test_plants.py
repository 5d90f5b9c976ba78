"""One conformance test over every plant: shapes, units, description, predefined law."""

from __future__ import annotations

import numpy as np
import pytest

from elab.errors import NotFound
from elab.plants import PLANTS, Plant, get_plant
from elab.sim import RunSpec, Step, compile_run, simulate
from tests.unit.conftest import discrete_loop

ALL = [pytest.param(p, id=p.id) for p in PLANTS.values()]


@pytest.mark.parametrize("plant", ALL)
def test_dimensions_agree(plant: Plant) -> None:
    nx, ny = plant.nx, plant.ny
    assert plant.A.shape == (nx, nx) and plant.B.shape == (nx, 1)
    assert plant.C.shape == (ny, nx) and plant.D.shape == (ny, 1)
    assert (len(plant.states), len(plant.inputs), len(plant.outputs)) == (nx, 1, ny)
    assert plant.operating_point.shape == (nx,)
    assert len(plant.sensors.quantum) == len(plant.sensors.noise_std) == ny
    assert 0 <= plant.reference_output < ny
    for vf in plant.velocity_filters:
        assert 0 <= vf.state < nx and 0 <= vf.output < ny and vf.omega_c > 0


@pytest.mark.parametrize("plant", ALL)
def test_units_and_names(plant: Plant) -> None:
    for group in (plant.states, plant.inputs, plant.outputs):
        assert len({c.name for c in group}) == len(group)
        assert all(c.unit and c.label for c in group)
    assert plant.inputs[0].unit == "V"
    assert plant.u_max > 0 and plant.Ts > 0


@pytest.mark.parametrize("plant", ALL)
def test_model_is_read_only(plant: Plant) -> None:
    with pytest.raises(ValueError, match="read-only"):
        plant.A[0, 0] = 1.0


@pytest.mark.parametrize("plant", ALL)
def test_description_has_equations_and_limits(plant: Plant) -> None:
    text = plant.description
    assert text.startswith(f"# {plant.name}")
    assert "$$" in text and "## Limits" in text and "## Experiments" in text


@pytest.mark.parametrize("plant", ALL)
def test_predefined_controller_stabilises_the_linear_model(plant: Plant) -> None:
    run = compile_run(RunSpec(plant, plant.predefined, saturate=False))
    poles = np.linalg.eigvals(discrete_loop(run).A)
    assert np.max(np.abs(poles)) < 1.0 - 1e-6


@pytest.mark.parametrize("plant", ALL)
def test_predefined_controller_reaches_the_reference(plant: Plant) -> None:
    amp = 0.1 * plant.signal.amplitude
    res = simulate(RunSpec(plant, plant.predefined, Step(amp), duration=120.0, saturate=False))
    y_ref = (
        res.y[-1, plant.reference_output]
        - (plant.C @ plant.operating_point)[plant.reference_output]
    )
    np.testing.assert_allclose(y_ref, amp, rtol=1e-3)  # integrator in every loop


def test_unknown_plant_names_the_known_ones() -> None:
    with pytest.raises(NotFound, match="known: belt_conveyor, double_pendulum, flexible_link"):
        get_plant("crane")
