"""A run's outcome (elab/engines/outcome.py) on real simulations, fed part by part as the
recorder commits them: the seed's LQR on a step has nothing to say; a pole at +5 saturates
and runs away (the issue's "finished" with θ at thousands of degrees); the pendulum's
unsaturated input goes beyond the actuator, and a push leaves the links' valid range.
Parts of any size give the same marks as the whole."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from elab.design import design_place
from elab.engines.outcome import (
    RUNAWAY,
    RUNAWAY_FLOOR,
    SATURATED_S,
    SATURATED_SHARE,
    OutcomeTracker,
)
from elab.engines.simulation import channels_of
from elab.laws import OpenLoop, StateFeedback
from elab.plants import get_plant
from elab.sim import RunSpec, Square, Step, compile_run, simulate

FLEX = get_plant("flexible_link")
PEND = get_plant("double_pendulum")


def rows(spec: RunSpec) -> tuple[OutcomeTracker, np.ndarray]:
    """A tracker for ``spec``'s run and its recorded rows (``r, u, y…, x…``)."""
    run = compile_run(spec)
    s = simulate(spec)
    data = np.column_stack([s.r, s.u, s.y, s.x])
    return OutcomeTracker.of(run, channels_of(run)), data


def marks(spec: RunSpec, part: int = 997) -> list[dict[str, object]]:
    tracker, data = rows(spec)
    for k0 in range(0, data.shape[0], part):
        tracker.add(k0, data[k0 : k0 + part])
    return tracker.marks()


def test_the_seeds_lqr_on_a_square_wave_has_nothing_to_say() -> None:
    spec = RunSpec(FLEX, FLEX.predefined, Square(math.radians(30), 4.0), duration=8.0)
    assert marks(spec) == []


def test_an_unstable_design_saturates_and_runs_away() -> None:
    """Pole placement with a pole at +5: u pinned at the limit from early on, θ far away."""
    K = design_place(FLEX, [5.0, -10.0, -20.0, -30.0]).K
    spec = RunSpec(FLEX, StateFeedback(tuple(K.ravel())), Step(math.radians(30)), duration=10.0)
    got = marks(spec)
    kinds = [m["kind"] for m in got]
    assert kinds == ["saturated", "ran_away"], got
    saturated, ran_away = got
    assert float(saturated["t"]) < 1.0  # pinned from the first second on
    assert "±10 V" in str(saturated["text"]) and "in a row" in str(saturated["text"])
    assert "unstable, or a sign is wrong" in str(ran_away["text"])
    # from the first sample of the stretch to the end where θ is 10 × 30° or more off
    _, data = rows(spec)
    near = np.flatnonzero(np.abs(data[:, 2] - data[:, 0]) <= 10 * math.radians(30))
    assert 0 < near[-1] + 1 < 9999 and ran_away["k"] == near[-1] + 1
    assert f"ran away from t = {(near[-1] + 1) * 1e-3:.4g} s" in str(ran_away["text"])


def test_open_loop_drift_is_not_a_runaway_but_its_saturation_is_said() -> None:
    """In open loop the reference is not a target: an integrating θ is no runaway. A
    constant 10 V (the limit) for the whole run is saturation."""
    spec = RunSpec(FLEX, OpenLoop(), Step(10.0), duration=3.0)
    got = marks(spec)
    assert [m["kind"] for m in got] == ["saturated"], got
    assert got[0]["k"] == 0


def test_the_pendulums_input_beyond_the_actuator_and_its_links_out_of_range() -> None:
    """Saturation off (the pendulum's default): the open-loop pendulum pushed at 12 V goes
    beyond ±10 V from the first sample and its links leave their valid range."""
    spec = RunSpec(PEND, OpenLoop(), Step(12.0), duration=3.0)
    got = {m["kind"]: m for m in marks(spec)}
    assert set(got) == {"beyond_actuator", "left_range"}, got
    assert got["beyond_actuator"]["k"] == 0 and "up to 12 V" in str(got["beyond_actuator"]["text"])
    assert "left the model's valid range" in str(got["left_range"]["text"])
    # the first sample outside is where the recording says
    _, data = rows(spec)
    beta1 = data[:, 3]
    lo, hi = PEND.output_ranges[0][1:]
    assert got["left_range"]["k"] == int(np.argmax((beta1 < lo) | (beta1 > hi)))


@pytest.mark.parametrize("part", [1, 7, 1000, 100_000])
def test_parts_of_any_size_give_the_marks_of_the_whole(part: int) -> None:
    K = design_place(FLEX, [5.0, -10.0, -20.0, -30.0]).K
    spec = RunSpec(FLEX, StateFeedback(tuple(K.ravel())), Step(math.radians(30)), duration=4.0)
    assert marks(spec, part) == marks(spec, 10**9)


def test_a_stretch_at_the_limit_spanning_parts_is_one_stretch() -> None:
    """Stretches of 0.6 s at the limit, split over parts: none alone makes SATURATED_S,
    a 1.2 s one split in the middle does."""
    tracker = OutcomeTracker(
        0.001, (("r", "V"), ("u", "V"), ("y", "rad")), u_max=10.0, saturate=True, feedback=False
    )
    u = np.zeros(5000)
    u[100:700] = 10.0  # 0.6 s
    u[2000:3200] = -10.0  # 1.2 s, split at 2500 below
    data = np.column_stack([np.zeros(5000), u, np.zeros(5000)])
    tracker.add(0, data[:2500])
    tracker.add(2500, data[2500:])
    (m,) = tracker.marks()
    assert m["kind"] == "saturated" and m["k"] == 2000 and SATURATED_S <= 1.2
    assert "1.2 s in a row from t = 2 s" in str(m["text"])


def test_dropped_samples_and_an_empty_run_are_quiet() -> None:
    tracker, data = rows(replace(RunSpec(FLEX, FLEX.predefined, Step(0.5), duration=2.0)))
    holed = data.copy()
    holed[500:520] = np.nan  # a rig's dropped samples
    tracker.add(0, holed)
    assert tracker.marks() == []
    empty, _ = rows(RunSpec(FLEX, FLEX.predefined, Step(0.5), duration=0.1))
    assert empty.marks() == []


def test_a_loop_held_at_zero_runs_away_only_far_from_it() -> None:
    """A regulation (r = 0) from a start 3° off: the seed's LQR brings θ back to 0 and has
    nothing to say (its small end error is no runaway); the pole at +5 from the same start
    runs away, said against the held reference."""
    x0 = (math.radians(3), 0.0, 0.0, 0.0)
    calm = RunSpec(FLEX, FLEX.predefined, Step(0.0), duration=3.0, x0=x0)
    assert marks(calm) == []
    K = design_place(FLEX, [5.0, -10.0, -20.0, -30.0]).K
    wild = RunSpec(FLEX, StateFeedback(tuple(K.ravel())), Step(0.0), duration=6.0, x0=x0)
    got = {m["kind"]: m for m in marks(wild)}
    assert "ran_away" in got, got
    assert "(held at 0)" in str(got["ran_away"]["text"])


WORDS = {0.1: "a tenth", 10.0: "10 times"}


def test_the_glossary_states_the_rules_the_code_applies() -> None:
    """The rules are written once for users (docs/glossary.md, *Outcome marks*, which the
    README and the other docs point to): its numbers are the module's constants."""
    glossary = (Path(__file__).parents[3] / "docs" / "glossary.md").read_text()
    entry = glossary.split("**Outcome marks.**", 1)[1].split("\n\n", 1)[0]
    text = " ".join(entry.split())
    assert f"{SATURATED_S:g} s in a row and {WORDS[SATURATED_SHARE]} of the run" in text
    assert f"more than {WORDS[RUNAWAY]} the reference's largest magnitude" in text
    floor = f"at least {math.degrees(RUNAWAY_FLOOR['rad']):g}° or {RUNAWAY_FLOOR['m'] * 1e3:g} mm"
    assert floor in text
