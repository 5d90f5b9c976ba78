"""Run orders cross the engine's process boundary as JSON and come back equal: every kind
of law (with an observer's complex poles, a feed-forward, setpoint weights and Python
code) and every signal."""

from __future__ import annotations

import json

import pytest

from elab.engines import wire
from elab.engines.base import NewParams, RunOrder
from elab.laws import PID, CodeController, LTIController, OpenLoop, StateFeedback
from elab.plants import get_plant
from elab.sim import PRBS, Chirp, RunSpec, Sine, Square, Step
from elab.store.base import ParamChange, RunRecord

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
    message = wire.command_out(wire.Add(7, order))
    head, _ = wire.lengths(message[: wire.HEADER_BYTES])
    back = wire.decode_command(message[wire.HEADER_BYTES : wire.HEADER_BYTES + head])
    assert back == wire.Add(7, order)


@pytest.mark.parametrize("law", LAWS[:2], ids=lambda law: type(law).__name__)
def test_a_start_and_a_change_carry_their_typed_parts_to_any_web_process(law: object) -> None:
    """On a broker every web process hears every run: ``Started`` carries the order it
    was started with, ``Params`` the new law and reference, as decoded from the wire."""
    order = RunOrder("r-2", RunSpec(FLEX, law, Square(0.5, 4.0), duration=1.0), "realtime",
                     "simulation", "analysis", {"plant": "flexible_link"}, owner="a-2")  # fmt: skip
    record = RunRecord(
        id="r-2", plant="flexible_link", mode="simulation", experiment="analysis",
        spec={}, status="running", Ts=0.001, channels=(("r", "rad"),), n_planned=1000,
        created_at=1.0, started_at=1.0, engine="sim-0", owner="a-2",
    )  # fmt: skip
    started = wire.decode_event(*wire.unframe(wire.event_out(wire.Started(record, order))))
    assert started == wire.Started(record, order)
    change = ParamChange(k=17, params={"signal": {"kind": "sine"}}, at=2.0)
    new = NewParams(law, Sine(0.2, 1.5), change.params)  # type: ignore[arg-type]
    params = wire.decode_event(*wire.unframe(wire.event_out(wire.Params("r-2", change, new))))
    assert params == wire.Params("r-2", change, new)
    bare = wire.decode_event(*wire.unframe(wire.event_out(wire.Params("r-2", change))))
    assert bare == wire.Params("r-2", change, None)


def test_a_follow_and_a_close_survive_the_wire() -> None:
    for cmd in (wire.Follow(5), wire.Close("told to")):
        message = wire.command_out(cmd)
        assert wire.decode_command(wire.unframe(message)[0]) == cmd


def _head(message: bytes) -> tuple[bytes, bytes]:
    head, size = wire.lengths(message[: wire.HEADER_BYTES])
    body = message[wire.HEADER_BYTES :]
    return body[:head], body[head : head + size]


def test_replies_keep_their_type_across_the_wire() -> None:
    channels = (("r", "rad"), ("u", "V"))
    record = RunRecord(
        id="r-1",
        plant="flexible_link",
        mode="simulation",
        experiment="design",
        status="running",
        Ts=1e-3,
        channels=channels,
        n_planned=9,
        spec={"duration": 0.009},
    )
    for ok in (record, 42, None):
        assert wire.decode_event(*_head(wire.event_out(wire.Reply(3, ok=ok)))) == wire.Reply(
            3, ok=ok
        )


def test_the_handshake_names_the_protocol_and_the_kind() -> None:
    ready = wire.decode_event(*_head(wire.event_out(wire.Ready("rig-0", 12, [], kind="rig"))))
    assert ready == wire.Ready("rig-0", 12, [], wire.PROTOCOL, "rig")


@pytest.mark.parametrize(
    "head",
    [b"not json", b"[1, 2]", b'{"op": "launch", "id": 5}', b'{"op": "control", "id": 9}'],
)
def test_an_unknown_command_is_unreadable_with_its_id(head: bytes) -> None:
    with pytest.raises(wire.Unreadable) as err:
        wire.decode_command(head)
    expected = json.loads(head)["id"] if head.startswith(b"{") else -1
    assert err.value.command_id == expected
