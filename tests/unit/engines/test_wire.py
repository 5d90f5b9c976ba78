"""Run orders cross the engine's process boundary as JSON and come back equal: every kind
of law (with an observer's complex poles, a feed-forward, setpoint weights and Python
code) and every signal."""

from __future__ import annotations

import json

import pytest

from elab.engines import wire
from elab.engines.base import RunOrder
from elab.laws import PID, CodeController, LTIController, OpenLoop, StateFeedback
from elab.plants import get_plant
from elab.sim import PRBS, Chirp, RunSpec, Sine, Square, Step

FLEX = get_plant("flexible_link")
LAWS = [
    StateFeedback((20.0, -93.5614, 3.3621, 0.9623), "velocity_filters"),
    StateFeedback(
        (1.0, 2.0, 3.0, 4.0), "observer", 5.0, None, (-40, complex(-50, 8), complex(-50, -8), -45)
    ),
    StateFeedback((1.0, 2.0, 3.0, 4.0), "observer", None, ((1.0, 0.0),) * 4),
    PID(12.0, 0.49, 0.5, 10.0, 2.0, b=0.5, c=0.0),
    LTIController(num=(1.0, 2.0), den=(1.0, 0.5), dt=0.001, ff_num=(0.5,), ff_den=(1.0, -0.5)),
    OpenLoop(),
    CodeController("class Controller:\n    def step(self, t, y, r):\n        return 0.0\n", "c.py"),
]
SIGNALS = [Step(0.1), Square(0.5, 4.0), Sine(0.2, 1.5), Chirp(0.1, 0.1, 10.0, 5.0), PRBS(1.0, 7)]


@pytest.mark.parametrize("law", LAWS, ids=lambda law: type(law).__name__)
@pytest.mark.parametrize("signal", SIGNALS, ids=lambda s: type(s).__name__)
def test_a_run_order_survives_the_wire(law: object, signal: object) -> None:
    order = RunOrder(
        "r-1",
        RunSpec(FLEX, law, signal, duration=2.0, noise_seed=3),
        "fast",  # type: ignore[arg-type]
        "simulation",
        "design",
        {"x": 1},
        owner="a-1",
    )
    back = wire.order_in(json.loads(json.dumps(wire.order_out(order))))
    assert back == order
