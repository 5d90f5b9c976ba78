"""The compiled loop's parts, called one by one, give the loop's samples bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from elab.plants import PLANTS
from elab.sim import PRBS, Batch, RunSpec, Square, compile_run, simulate
from elab.sim.kernel import control_step, measure, plant_step


@pytest.mark.parametrize("plant", list(PLANTS.values()), ids=list(PLANTS))
@pytest.mark.parametrize("noise", [False, True])
def test_measure_control_and_plant_steps_alone_reproduce_simulate(
    plant: object, noise: bool
) -> None:
    spec = RunSpec(
        plant,
        plant.predefined,
        Square(0.2, 1.0),
        duration=0.5,  # type: ignore[attr-defined]
        excitation=PRBS(0.3),
        noise_seed=7 if noise else None,
        quantize=noise,
    )
    whole = simulate(spec)
    run = compile_run(spec)
    batch = Batch(capacity=1, block=run.n_samples)  # its arrays hold one run, in slot 0
    batch.add(run)
    a = {k: v.copy() for k, v in batch._a.items()}
    exo = run.exogenous(0, run.n_samples)
    p, NX, NY = run.spec.plant, a["x"].shape[1], a["C"].shape[1]
    y, xn, xcn = np.zeros(NY), np.zeros(NX), np.zeros(a["xc"].shape[1])
    use_state = run.controller.feedback == "state"
    u_seen, y_seen = [], []
    for k in range(run.n_samples):
        v = np.zeros(NY)
        v[: p.ny] = exo[k, 2:]
        measure(0, a["C"], a["x"], v, a["quantum"], y)
        z = np.zeros(a["Dc"].shape[1] - 1)
        z[: NX if use_state else NY] = a["x"][0] if use_state else y
        u = control_step(
            0,
            exo[k, 0],
            z,
            exo[k, 1],
            a["Ac"],
            a["Bc"],
            a["Cc"],
            a["Dc"],
            a["Lw"],
            a["u_lim"],
            a["xc"],
            xcn,
        )
        plant_step(0, a["Ad"], a["Bd"], a["x"], u, xn)
        a["xc"][0], a["x"][0] = xcn, xn  # the caller commits the next states
        u_seen.append(u)
        y_seen.append(y[: p.ny] + a["y_op"][0, : p.ny])
    np.testing.assert_array_equal(np.array(u_seen), whole.u)  # bit for bit
    np.testing.assert_array_equal(np.array(y_seen), whole.y)
