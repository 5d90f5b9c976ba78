"""Each plant's default analysis run (its reference, start and duration as the analysis
page proposes them) ends settled (issue 27): the belt conveyor's ended 12 % over its step
and still moving at 20 s. Checked on the noise-free simulation of the predefined
controller: the reference output within 2 % of each step of the reference (as the design
page's settling time) over the last tenth of every span the reference holds, and the
span's settling time within it."""

from __future__ import annotations

import numpy as np
import pytest

from elab.plants import PLANTS, get_plant
from elab.runs.prediction import step_response_info, step_segments
from elab.sim import RunSpec, Square, Step, simulate

BAND = 0.02


@pytest.mark.parametrize("plant_id", sorted(PLANTS))
def test_the_default_run_settles_within_its_duration(plant_id: str) -> None:
    p = get_plant(plant_id)
    d = p.signal
    signal = Square(d.amplitude, d.period) if d.kind == "square" else Step(d.amplitude)
    spec = RunSpec(p, p.predefined, signal, duration=d.duration, x0=d.x0)
    s = simulate(spec)
    offset = float((p.C @ p.operating_point)[p.reference_output])
    y = s.y[:, p.reference_output] - offset
    spans = step_segments(s.r)
    assert spans, "the default reference holds its values"
    for k0, k1 in spans:
        target = float(s.r[k0])
        step = abs(target - (float(s.r[k0 - 1]) if k0 else float(y[0])))
        tail = y[k1 - max((k1 - k0) // 10, 1) : k1]
        worst = float(np.max(np.abs(tail - target)))
        assert worst <= BAND * step, (plant_id, k0 * p.Ts, worst, step)
        info = step_response_info(y[k0:k1], p.Ts, float(y[k0]), target)
        assert info is not None and info.settling_time < (k1 - k0) * p.Ts, (plant_id, info)
