"""``GET /runs/{id}/prediction`` on a real server: the model's prediction of a run beside
its recording. A noise-free simulation run is its own prediction (the same loop: gaps
of round-off only), also across a live change of gains, which the prediction replays at
its sample; with sensor noise the gap is the noise; a Python controller's prediction
steps it in its sandbox; unknown and hidden runs are 404. The rig's prediction (the
nominal model against the emulator) is in tests/api/test_rig.py."""

from __future__ import annotations

import math
from typing import Any

import control as ct
import httpx
import numpy as np
import pytest

from elab.controllers.sandbox import available
from elab.laws import StateFeedback
from elab.plants import get_plant
from elab.sim import RunSpec, Square, simulate
from tests.api.server import Server, until
from tests.api.test_code_controllers import SEED_LQR, SOURCE, upload

FLEX = get_plant("flexible_link")
SQUARE = {"kind": "square", "amplitude": math.radians(30), "period": 2.0}
ROUND_OFF = 1e-9  # rad or V: the same loop gives the same numbers


def ended(c: httpx.Client, run_id: str) -> dict[str, Any]:
    def done() -> dict[str, Any] | None:
        run: dict[str, Any] = c.get(f"/runs/{run_id}").json()
        return run if run["finished_at"] else None

    return until(done, 120)


def gaps(pred: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {g["name"]: g for g in pred["gaps"]}


def test_a_noise_free_simulation_is_its_own_prediction(server: Server) -> None:
    with server.client() as c:
        run = c.post(
            "/runs",
            json={"plant": "flexible_link", "pace": "fast", "duration": 3, "signal": SQUARE},
        ).json()
        assert ended(c, run["id"])["status"] == "finished"
        r = c.get(f"/runs/{run['id']}/prediction")
        assert r.status_code == 200, r.text
        pred = r.json()
    assert pred["n"] == pred["compared"] == 3000 and pred["replayed"] == 0
    assert [ch["name"] for ch in pred["channels"]] == ["u", "theta", "alpha"]
    assert all(len(ch["values"]) == 3000 for ch in pred["channels"])
    assert "ideal sensors" in pred["model"] and pred["diverged_at"] is None
    for g in pred["gaps"]:
        assert g["max_abs"] <= ROUND_OFF and g["rms"] <= ROUND_OFF, g
    # and it is the model's response: the same run simulated here
    sim = simulate(
        RunSpec(
            FLEX, StateFeedback(SEED_LQR, "velocity_filters"), Square(math.radians(30), 2.0), 3.0
        )
    )
    theta = np.array(pred["channels"][1]["values"])
    assert np.max(np.abs(theta - sim.y[:, 0])) < 1e-6
    # each step of the square wave: the run's characteristics are the prediction's, and
    # python-control's step_info of the recording's own samples
    with server.client() as c:
        rec = c.get(f"/runs/{run['id']}/data?format=json").json()
    t, y = np.array(rec["t"]), np.array(rec["data"]["theta"])
    assert [(st["t"], st["span"]) for st in pred["steps"]] == [(0.0, 1.0), (1.0, 1.0), (2.0, 1.0)]
    for st, sign in zip(pred["steps"], (1, -1, 1), strict=True):
        assert st["output"] == "theta" and st["unit"] == "rad"
        assert st["target"] == pytest.approx(sign * math.radians(30))
        for key, value in st["run"].items():
            assert value == pytest.approx(st["prediction"][key], abs=1e-6), key
        k = (t >= st["t"] - 1e-9) & (t < st["t"] + st["span"] - 1e-9)
        seg = y[k] - st["start"]
        theirs = ct.step_info(seg, t[k] - st["t"])
        assert st["start"] == pytest.approx(y[k][0])
        assert st["run"]["overshoot"] == pytest.approx(theirs["Overshoot"], abs=1e-6)
        assert st["run"]["rise_time"] == pytest.approx(theirs["RiseTime"], abs=1.5e-3)
        assert st["run"]["settling_time"] == pytest.approx(theirs["SettlingTime"], abs=1.5e-3)
        assert st["run"]["overshoot"] > 1  # the seed's LQR overshoots a little on θ


def test_a_live_change_is_replayed_at_its_sample(server: Server) -> None:
    slower = {"kind": "state_feedback", "K": [8.0, -40.0, 1.5, 0.4]}
    with server.client() as c:
        run = c.post(
            "/runs", json={"plant": "flexible_link", "duration": 4, "signal": SQUARE}
        ).json()
        until(lambda: c.get(f"/runs/{run['id']}").json()["n_samples"] > 800, 60)
        changed = c.post(f"/runs/{run['id']}/params", json={"controller": slower})
        assert changed.status_code == 200, changed.text
        k = changed.json()["k"]
        assert ended(c, run["id"])["status"] == "finished"
        pred = c.get(f"/runs/{run['id']}/prediction").json()
    assert pred["replayed"] == 1 and pred["compared"] == 4000
    for g in pred["gaps"]:
        assert g["max_abs"] <= ROUND_OFF, g
    # the change mattered: without it the run would have gone elsewhere after sample k
    alone = simulate(
        RunSpec(
            FLEX, StateFeedback(SEED_LQR, "velocity_filters"), Square(math.radians(30), 2.0), 4.0
        )
    )
    theta = np.array(pred["channels"][1]["values"])
    assert np.max(np.abs(theta[:k] - alone.y[:k, 0])) < 1e-6
    assert np.max(np.abs(theta[k:] - alone.y[k:, 0])) > math.radians(1)


def test_with_sensor_noise_the_gap_is_the_noise(server: Server) -> None:
    with server.client() as c:
        plant = c.get("/plants/flexible_link").json()
        std = dict(
            zip([o["name"] for o in plant["outputs"]], plant["sensors"]["noise_std"], strict=True)
        )
        body = {"plant": "flexible_link", "pace": "fast", "duration": 5, "seed": 3}
        run = c.post("/runs", json={**body, "signal": SQUARE}).json()
        ended(c, run["id"])
        g = gaps(c.get(f"/runs/{run['id']}/prediction").json())
    # the loop feeds the noise back, so the outputs' gap is the noise and a little more
    for name in ("theta", "alpha"):
        assert 0.5 * std[name] < g[name]["rms"] < 3 * std[name], (name, g[name], std)


@pytest.mark.skipif(available() is not None, reason=str(available()))
def test_a_python_controller_is_predicted_in_its_sandbox(server: Server) -> None:
    with server.client() as c:
        up = upload(c, SOURCE)
        body = {"plant": "flexible_link", "pace": "fast", "duration": 2, "signal": SQUARE}
        first, second = (
            c.post("/runs", json={**body, "controller_id": up["id"]}).json() for _ in range(2)
        )
        assert ended(c, first["id"])["status"] == "finished"
        pred = c.get(f"/runs/{first['id']}/prediction").json()
        # the same code on the same model: the run is its prediction
        assert pred["compared"] == 2000
        for g in pred["gaps"]:
            assert g["max_abs"] <= ROUND_OFF, g
        # deleted, a Python controller cannot be predicted any more: 409 says why
        ended(c, second["id"])
        assert c.delete(f"/controllers/{up['id']}").status_code == 204
        gone = c.get(f"/runs/{second['id']}/prediction")
    assert gone.status_code == 409 and "deleted" in gone.text, gone.text


def test_unknown_and_hidden_runs_have_no_prediction(server: Server) -> None:
    with server.client() as c:
        r = c.get("/runs/nope/prediction")
        assert r.status_code == 404 and "nope" in r.text
        run = c.post(
            "/runs",
            json={"plant": "flexible_link", "pace": "fast", "duration": 1, "private": True},
        ).json()
    with server.visitor().client() as other:
        assert other.get(f"/runs/{run['id']}/prediction").status_code == 404
