"""What a live change alters (``elab.api.changes``): defining properties of the diff, and the
values a run uses after its recorded changes."""

from __future__ import annotations

import math
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from elab.api import changes
from elab.plants import get_plant
from elab.store.base import ParamChange, RunRecord

FLEX = get_plant("flexible_link")

scalars = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False),
    st.integers(-(2**31), 2**31),
    st.sampled_from(["square", "sine", "velocity_filters"]),
    st.booleans(),
    st.none(),
)
values = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.sampled_from("abcK"), inner),
    max_leaves=12,
)
params = st.dictionaries(st.sampled_from(["kind", "amplitude", "K", "period", "L"]), values)


def flat(part: str, value: Any) -> dict[str, Any]:
    return dict(changes._flat(part, value))


@given(params)
def test_a_value_differs_from_itself_in_nothing(p: dict[str, Any]) -> None:
    assert changes.diff("signal", p, p) == []


@given(params, params)
def test_the_diff_lists_exactly_the_values_that_differ(
    a: dict[str, Any], b: dict[str, Any]
) -> None:
    d = changes.diff("signal", a, b)
    old, new = flat("signal", a), flat("signal", b)
    listed = {x.field for x in d}
    assert len(listed) == len(d)  # each field once
    for x in d:  # each one does differ, and says from what to what
        assert x.before == old.get(x.field) and x.after == new.get(x.field)
    # and everything not listed is the same before and after
    for key in (old.keys() | new.keys()) - listed:
        assert changes._same(old.get(key), new.get(key))


def test_numbers_a_rounding_apart_are_the_same_value() -> None:
    typed = 30 / (180 / math.pi)  # 30° typed in the page, sent in radians
    assert changes.diff("signal", {"amplitude": math.radians(30)}, {"amplitude": typed}) == []
    assert changes.diff("signal", {"amplitude": 0.0}, {"amplitude": 1e-300}) != []
    assert changes.diff("signal", {"order": 1}, {"order": True}) != []  # true is not 1


def test_the_run_uses_its_request_then_each_recorded_change() -> None:
    square = {"kind": "square", "amplitude": 0.5, "period": 4.0, "offset": 0.0, "duty": 0.5}
    record = RunRecord(
        id="r-1",
        plant=FLEX.id,
        mode="simulation",
        experiment="analysis",
        status="running",
        Ts=FLEX.Ts,
        channels=(),
        n_planned=1000,
        n_stored=10,
        created_at=0.0,
        started_at=0.0,
        finished_at=None,
        error=None,
        spec={"controller": {"kind": "predefined"}, "signal": square},
    )
    now = changes.running(record, [], FLEX)
    assert now["controller"]["K"] == list(FLEX.predefined.K)  # type: ignore[attr-defined]
    later = [
        ParamChange(k=5, params={"signal": {**square, "amplitude": 1.0}}, at=0.0),
        ParamChange(k=7, params={"controller": {"kind": "pid", "Kp": 2.0}}, at=0.0),
    ]
    now = changes.running(record, later, FLEX)
    assert now == {"controller": {"kind": "pid", "Kp": 2.0}, "signal": {**square, "amplitude": 1.0}}
