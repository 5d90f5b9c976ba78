"""Issue 15 on a real server: Apply changes the reference too and says what changed;
edge inputs are refused by field; identification runs measure like real sensors by
default and their downloads say so; an unstable open-loop step is cut at the plant's range;
the pendulum's default analysis run moves every output."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from elab.api import convert
from elab.api import schemas as s
from elab.plants import get_plant
from elab.sim import simulate
from tests.api.server import Server, until

FLEX = get_plant("flexible_link")
PEND = get_plant("double_pendulum")
SQUARE = {"kind": "square", "amplitude": math.radians(30), "period": 1.0}
VISIBLE = math.radians(0.25)  # about 3 encoder counts: a motion a student sees


def _started(c: Any, body: dict[str, Any], samples: int = 300) -> str:
    r = c.post("/runs", json=body)
    assert r.status_code == 201, r.text
    rid: str = r.json()["id"]
    until(lambda: c.get(f"/runs/{rid}").json()["n_samples"] >= samples)
    return rid


def test_apply_of_a_new_amplitude_changes_the_reference_from_the_recorded_sample(
    server: Server,
) -> None:
    with server.client() as c:
        rid = _started(c, {"plant": "flexible_link", "signal": SQUARE, "duration": 30})
        new = {**SQUARE, "amplitude": math.radians(60)}
        r = c.post(f"/runs/{rid}/params", json={"signal": new})
        assert r.status_code == 200, r.text
        applied = r.json()
        k = applied["k"]
        assert applied["changed"] == [
            {"field": "signal.amplitude", "before": SQUARE["amplitude"], "after": new["amplitude"]}
        ]
        # the same values again (gains included, as the page sends them): nothing changes
        same = c.post(
            f"/runs/{rid}/params",
            json={"signal": new, "controller": {"kind": "predefined"}},
        ).json()
        assert same["changed"] == []
        # gains and offset at once: both are named, field by field
        K = list(FLEX.predefined.K)  # type: ignore[attr-defined]
        both = c.post(
            f"/runs/{rid}/params",
            json={
                "controller": {"kind": "state_feedback", "K": [25.0, *K[1:]]},
                "signal": {**new, "offset": math.radians(5)},
            },
        ).json()
        assert [(d["field"], d["after"]) for d in both["changed"]] == [
            ("controller.K.0", 25.0),
            ("signal.offset", math.radians(5)),
        ]
        until(lambda: c.get(f"/runs/{rid}").json()["n_samples"] > both["k"] + 10)
        c.post(f"/runs/{rid}/stop")
        info = c.get(f"/runs/{rid}").json()
        assert [p["k"] for p in info["param_changes"]] == [k, both["k"]]  # not the no-op
        assert set(info["param_changes"][1]["params"]) == {"controller", "signal"}
        r_ = np.array(c.get(f"/runs/{rid}/data?format=json&channels=r").json()["data"]["r"])
        # the recorded reference: ±30° up to sample k, ±60° from k on, then offset by 5°
        np.testing.assert_allclose(np.abs(r_[:k]), math.radians(30), rtol=1e-12)
        np.testing.assert_allclose(np.abs(r_[k : both["k"]]), math.radians(60), rtol=1e-12)
        np.testing.assert_allclose(
            np.abs(r_[both["k"] :] - math.radians(5)), math.radians(60), rtol=1e-12
        )


@pytest.mark.parametrize(
    ("change", "field", "words"),
    [
        ({"signal": {**SQUARE, "period": 0.002}}, "signal.period", "at least 4 samples"),
        ({"signal": {**SQUARE, "amplitude": "0x10"}}, "signal.square.amplitude", "number"),
        ({"signal": {"kind": "sine", "amplitude": 0.1, "frequency": 300}}, "signal.frequency", ""),
        ({"controller": {"kind": "state_feedback", "K": [1.0, 2.0]}}, "controller.K", "4 gains"),
    ],
)
def test_a_bad_live_change_is_refused_by_field_and_changes_nothing(
    server: Server, change: dict[str, Any], field: str, words: str
) -> None:
    with server.client() as c:
        rid = _started(c, {"plant": "flexible_link", "signal": SQUARE, "duration": 30}, 50)
        r = c.post(f"/runs/{rid}/params", json=change)
        c.post(f"/runs/{rid}/stop")
        assert r.status_code == 422, r.text
        err = r.json()["error"]
        named = [err["field"], *(e["field"] for e in err["errors"])]
        assert field in named, err
        assert words in err["message"] + " ".join(e["message"] for e in err["errors"])
        assert c.get(f"/runs/{rid}").json()["param_changes"] == []


@pytest.mark.parametrize(
    ("body", "field", "words"),
    [
        ({"duration": 1e-9}, "duration", "at least 10 samples: a duration ≥ 0.01 s"),
        ({"duration": 0.009}, "duration", "at least 10 samples"),
        ({"duration": "0x10"}, "duration", "number"),
        ({"signal": {**SQUARE, "period": 0.0005}}, "signal.period", "a period ≥ 0.004 s"),
        ({"signal": {"kind": "sine", "amplitude": 1, "frequency": 251}}, "signal.frequency", "250"),
        (
            {"excitation": {"kind": "sine", "amplitude": 1, "frequency": 400}},
            "excitation.frequency",
            "≤ 250 Hz",
        ),
        ({"experiment": "identification", "noise": False, "seed": 3}, "seed", "noise false"),
    ],
)
def test_edge_inputs_are_refused_naming_field_value_and_what_is_allowed(
    server: Server, body: dict[str, Any], field: str, words: str
) -> None:
    with server.client() as c:
        r = c.post("/runs", json={"plant": "flexible_link", "pace": "fast", **body})
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    text = err["message"] + " ".join(e["message"] for e in err["errors"])
    assert field in [err["field"], *(e["field"] for e in err["errors"])], err
    assert words in text, text


def test_the_shortest_run_and_period_allowed_are_taken(server: Server) -> None:
    with server.client() as c:
        r = c.post(
            "/runs",
            json={
                "plant": "flexible_link",
                "pace": "fast",
                "duration": 0.01,
                "signal": {**SQUARE, "period": 0.004},
            },
        )
        assert r.status_code == 201, r.text
        rid = r.json()["id"]
        info = until(lambda: (i := c.get(f"/runs/{rid}").json())["status"] == "finished" and i)
        assert info["n_samples"] == 10
        assert c.get(f"/runs/{rid}/data", params={"t_from": "1_0"}).status_code == 422


def _header(text: str) -> dict[str, str]:
    lines = [line[2:] for line in text.splitlines() if line.startswith("# ")]
    return dict(line.split(": ", 1) for line in lines)


def _finished(c: Any, body: dict[str, Any]) -> dict[str, Any]:
    r = c.post("/runs", json={"pace": "fast", **body})
    assert r.status_code == 201, r.text
    rid = r.json()["id"]
    info: dict[str, Any] = until(
        lambda: (i := c.get(f"/runs/{rid}").json())["status"] == "finished" and i
    )
    return info


def test_identification_runs_measure_like_real_sensors_and_say_so(server: Server) -> None:
    excitation = {"kind": "prbs", "amplitude": 1.0, "band": 0.05}
    with server.client() as c:
        ident = _finished(
            c,
            {
                "plant": "flexible_link",
                "experiment": "identification",
                "excitation": excitation,
                "duration": 2,
            },
        )
        req = ident["request"]
        assert req["noise"] is True and isinstance(req["seed"], int) and req["quantize"] is True
        head = _header(c.get(f"/runs/{ident['id']}/data").text)
        assert head["noise"] == (
            f"white, standard deviation theta 0.0002 rad, alpha 0.0002 rad (seed {req['seed']})"
        )
        assert head["quantisation"] == (
            "theta 0.00153398 rad, alpha 0.00153398 rad (the sensors' resolution)"
        )
        data = c.get(f"/runs/{ident['id']}/data?format=json").json()["data"]
        counts = np.array(data["theta"]) / FLEX.sensors.quantum[0]
        np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)  # whole encoder counts
        assert np.unique(np.round(counts)).size > 3  # and it moved
        # the recorded request repeats the run bit for bit offline (its seed included)
        offline = simulate(convert.run_spec(s.RunCreate.model_validate(req), FLEX))
        np.testing.assert_array_equal(np.array(data["theta"]), offline.y[:, 0])

        ideal = _finished(
            c,
            {
                "plant": "flexible_link",
                "experiment": "identification",
                "excitation": excitation,
                "duration": 0.1,
                "noise": False,
                "quantize": False,
            },
        )
        assert ideal["request"]["seed"] is None
        analysis = _finished(c, {"plant": "flexible_link", "duration": 0.1})
        for info in (ideal, analysis):
            head = _header(c.get(f"/runs/{info['id']}/data").text)
            assert head["noise"] == head["quantisation"] == "none (ideal sensors)"


def test_the_pendulums_open_loop_step_is_cut_where_it_leaves_the_model(server: Server) -> None:
    """Issue 15: the open-loop step integrated the unstable model to 1.5e199°."""
    with server.client() as c:
        out = c.post("/plants/double_pendulum/step", json={}).json()
        flex = c.post("/plants/flexible_link/step", json={}).json()
    cut = out["cut"]
    assert cut["output"] == "beta1" and cut["high"] == pytest.approx(math.radians(10))
    beta1 = np.array(out["outputs"]["beta1"])
    assert out["t"][-1] == cut["t"] and 1.0 < cut["t"] < 1.5  # β1 passes 10° after 1.27 s
    assert abs(beta1[-1]) > cut["high"] and np.all(np.abs(beta1[:-1]) <= cut["high"])
    assert len(out["t"]) > 1000  # sampled finely up to the exit, not 29 points of 2001
    assert flex["cut"] is None and flex["t"][-1] > 1.0  # marginally stable: no range, no cut


def test_the_pendulums_default_analysis_run_moves_every_output(server: Server) -> None:
    with server.client() as c:
        plant = c.get("/plants/double_pendulum").json()
        info = _finished(
            c,
            {
                "plant": "double_pendulum",
                "x0": plant["default_x0"],
                "signal": plant["default_signal"],
                "duration": plant["default_duration"],
            },
        )
        data = c.get(f"/runs/{info['id']}/data?format=json").json()["data"]
    assert info["n_samples"] == round(plant["default_duration"] / plant["Ts"])
    for o in ("alpha", "beta1", "beta2"):
        assert np.ptp(data[o]) > VISIBLE, o
    # the disc swings away to catch pendulum 1, then most of the way to its 10° reference
    assert min(data["alpha"]) < -math.radians(20) and data["alpha"][-1] > math.radians(5)
