"""Shared fixtures: the seed's reference numbers and independent loop builders."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import control as ct
import numpy as np
import pytest

from elab.sim.spec import CompiledRun

# the team folder beside the checkout holds the seed's numbers
SEED_FACTS = Path(__file__).resolve().parents[1] / "reference" / "seed_facts.json"


@pytest.fixture(scope="session")
def seed_facts() -> dict[str, Any]:
    return json.loads(SEED_FACTS.read_text())  # type: ignore[no-any-return]


def discrete_loop(run: CompiledRun) -> ct.StateSpace:
    """The run's linear loop (no saturation, no anti-windup) built by python-control.

    Independent of the stepping loop: plant ``c2d(zoh)`` and the discrete
    controller joined by ``ct.interconnect``; input ``r``, outputs ``y`` then ``u``.
    """
    p, c, Ts = run.spec.plant, run.controller, run.Ts
    zs = [f"z{i}" for i in range(c.Dc.size - 1)]
    ys = [f"y{i}" for i in range(p.ny)]
    Cz = np.eye(p.nx) if c.feedback == "state" else p.C
    plant = ct.ss(
        ct.c2d(ct.ss(p.A, p.B, np.vstack([p.C, Cz]), 0), Ts, "zoh"),
        inputs=["u"],
        outputs=ys + zs,
        name="plant",
    )
    nc, nw = c.nc, c.Dc.size
    ctrl = ct.ss(
        c.Ac.reshape(nc, nc),
        c.Bc.reshape(nc, nw),
        c.Cc.reshape(1, nc),
        c.Dc.reshape(1, nw),
        Ts,
        inputs=["r", *zs],
        outputs=["u"],
        name="ctrl",
    )
    return ct.interconnect([plant, ctrl], inplist=["r"], outlist=[*ys, "u"])
