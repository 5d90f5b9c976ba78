"""What a live change alters (``elab.runs.changes``): defining properties of the diff on
typed laws and signals, its fields named as in a request, and the decision a run takes."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import TypeAdapter

from elab.api import convert
from elab.api import schemas as s
from elab.errors import InvalidInput
from elab.laws import PID, CodeController, ControlLaw, LTIController, OpenLoop, StateFeedback
from elab.plants import PLANTS, get_plant
from elab.runs import changes
from elab.runs.changes import Change, RunParams
from elab.sim.signals import PRBS, Chirp, Samples, Signal, Sine, Square, Step, signal_kind

FLEX = get_plant("flexible_link")
SIGNAL: TypeAdapter[s.Signal] = TypeAdapter(s.Signal)

numbers = st.floats(-1e6, 1e6, allow_nan=False).filter(lambda x: x != 0) | st.sampled_from(
    [0.0, 1.0, -2.5]
)
vectors = st.lists(numbers, min_size=1, max_size=4).map(tuple)
matrices = st.lists(vectors, min_size=1, max_size=3).map(tuple)
positive = st.floats(1e-3, 1e3)

laws: st.SearchStrategy[ControlLaw] = st.one_of(
    st.builds(
        StateFeedback,
        vectors,
        st.sampled_from(["true_state", "velocity_filters", "observer"]),
        st.none() | numbers,
        st.none() | matrices,
        st.none() | st.lists(st.complex_numbers(max_magnitude=50), max_size=3).map(tuple),
    ),
    st.builds(PID, numbers, numbers, numbers, positive, st.none() | positive, numbers, numbers),
    st.builds(
        LTIController,
        num=st.none() | vectors,
        den=st.none() | vectors,
        A=st.none() | matrices,
        dt=st.none() | positive,
    ),
    st.just(OpenLoop()),
)
signals: st.SearchStrategy[Signal] = st.one_of(
    st.builds(Step, numbers, positive, numbers),
    st.builds(Square, numbers, positive, numbers, st.floats(0.01, 1.0)),
    st.builds(Sine, numbers, positive, numbers, numbers),
    st.builds(Chirp, numbers, positive, positive, positive, numbers),
    st.builds(PRBS, numbers, st.integers(3, 20), st.floats(0.01, 1.0), numbers),
    st.builds(Samples, vectors),
)


def json_flat(path: str, value: Any) -> Iterator[tuple[str, Any]]:
    """A request's JSON as ``(field, value)`` pairs, as clients and the page read it."""
    if isinstance(value, dict):
        for key, v in value.items():
            yield from json_flat(f"{path}.{key}", v)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from json_flat(f"{path}.{i}", v)
    else:
        yield path, value


def law_flat(law: ControlLaw) -> list[tuple[str, Any]]:
    return list(changes.flat("controller", convert.law_model(law).kind, law))


@given(laws)
def test_a_law_is_named_field_by_field_as_in_a_request(law: ControlLaw) -> None:
    """The answer's fields and values are those of the law's JSON in a request, in order."""
    wire = convert.law_model(law).model_dump(mode="json")
    assert law_flat(law) == list(json_flat("controller", wire))


@given(signals)
def test_a_signal_is_named_field_by_field_as_in_a_request(signal: Signal) -> None:
    asked = {"kind": signal_kind(signal), **dataclasses.asdict(signal)}
    wire = SIGNAL.validate_json(json.dumps(asked))
    assert convert.signal(wire) == signal
    flat = list(changes.flat("signal", wire.kind, signal))
    assert flat == list(json_flat("signal", wire.model_dump(mode="json")))


@pytest.mark.parametrize("plant", PLANTS)
def test_every_plants_predefined_law_reads_as_its_request(plant: str) -> None:
    law = get_plant(plant).predefined
    assert law_flat(law) == list(
        json_flat("controller", convert.law_model(law).model_dump(mode="json"))
    )


@given(laws)
def test_a_law_differs_from_itself_in_nothing(law: ControlLaw) -> None:
    assert changes.law_differences(law, law) == ()


@given(laws, laws)
def test_the_diff_lists_exactly_the_values_that_differ(a: ControlLaw, b: ControlLaw) -> None:
    d = changes.law_differences(a, b)
    old, new = dict(law_flat(a)), dict(law_flat(b))
    listed = {x.field for x in d}
    assert len(listed) == len(d)  # each field once
    for x in d:  # each one does differ, and says from what to what
        assert x.before == old.get(x.field) and x.after == new.get(x.field)
    # and everything not listed is the same before and after
    for key in (old.keys() | new.keys()) - listed:
        assert changes.same(old.get(key), new.get(key))


def test_numbers_a_rounding_apart_are_the_same_value() -> None:
    typed = 30 / (180 / math.pi)  # 30° typed in the page, sent in radians
    assert changes.signal_differences(Step(math.radians(30)), Step(typed)) == ()
    assert changes.signal_differences(Step(0.0), Step(1e-300)) != ()
    assert not changes.same(1, True)  # true is not 1


def test_a_change_keeps_the_parts_that_alter_something() -> None:
    square = Square(0.5, 4.0)
    now = RunParams(FLEX.predefined, square)
    asked = {"controller": {"kind": "predefined"}, "signal": {"kind": "square"}}
    same = changes.decide(now, Change(FLEX.predefined, square, asked=asked))
    assert same.new is None and same.changed == ()
    louder = Square(1.0, 4.0)
    d = changes.decide(now, Change(FLEX.predefined, louder, asked=asked))
    assert d.new is not None and d.new.law is None and d.new.reference == louder
    assert d.new.asked == {"signal": {"kind": "square"}}
    assert [(x.field, x.before, x.after) for x in d.changed] == [("signal.amplitude", 0.5, 1.0)]
    assert now.after(d.new) == RunParams(FLEX.predefined, louder)
    pid = changes.decide(now, Change(PID(2.0), asked={"controller": {}, "controller_id": "c"}))
    assert pid.new is not None and pid.new.asked == {"controller": {}, "controller_id": "c"}
    assert pid.changed[0] == changes.Difference("controller.kind", "state_feedback", "pid")


def test_code_is_never_swapped_into_or_out_of_a_live_run() -> None:
    code = CodeController("class Controller: ...")
    with pytest.raises(InvalidInput) as refused:
        Change(code, controller_id="c-1")
    assert refused.value.field == "controller_id" and refused.value.value == "c-1"
    now = RunParams(code, Step(1.0))
    with pytest.raises(InvalidInput, match="mid-run") as out:
        changes.decide(now, Change(PID(1.0)))
    assert out.value.field == "controller"
    d = changes.decide(now, Change(reference=Step(2.0)))  # a new reference is taken
    assert d.new is not None and d.new.reference == Step(2.0) and d.new.law is None
