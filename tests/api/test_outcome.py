"""A run's outcome on a real server (elab/engines/outcome.py): what "finished" alone
would hide, stored with the run's end and shown in ``GET /runs/{id}``, in the list and in
the CSV header. The issue's case: a pole-placement design with a pole at +5 ran with θ at
thousands of degrees and u pinned at −10 V, and ended a green "finished"."""

from __future__ import annotations

import math
from typing import Any

import httpx
import numpy as np

from elab.design import design_place
from elab.plants import get_plant
from tests.api.server import Server, until

FLEX = get_plant("flexible_link")
STEP = {"kind": "step", "amplitude": math.radians(30)}


def ended(c: httpx.Client, run_id: str) -> dict[str, Any]:
    """The run's record once its end (and the outcome written with it) is stored."""

    def done() -> dict[str, Any] | None:
        run: dict[str, Any] = c.get(f"/runs/{run_id}").json()
        return run if run["finished_at"] and run["outcome"] is not None else None

    return until(done, 120)


def test_an_unstable_design_is_marked_on_its_record_in_the_list_and_in_its_csv(
    server: Server,
) -> None:
    K = design_place(FLEX, [5.0, -10.0, -20.0, -30.0]).K.ravel().tolist()
    with server.client() as c:
        good = c.post(
            "/runs", json={"plant": "flexible_link", "pace": "fast", "duration": 5, "signal": STEP}
        ).json()
        bad = c.post(
            "/runs",
            json={
                "plant": "flexible_link",
                "pace": "fast",
                "duration": 5,
                "signal": STEP,
                "experiment": "design",
                "controller": {"kind": "state_feedback", "K": K},
            },
        ).json()
        assert ended(c, good["id"])["outcome"] == []  # the seed's LQR: nothing to say
        run = ended(c, bad["id"])
        assert run["status"] == "finished"
        kinds = [m["kind"] for m in run["outcome"]]
        assert kinds == ["saturated", "ran_away"], run["outcome"]
        saturated, ran_away = run["outcome"]
        assert saturated["t"] == saturated["k"] * 1e-3 and saturated["t"] < 1.0
        assert "unstable, or a sign is wrong" in ran_away["text"]
        # where it ran away: from the recording, the first sample of the stretch to the end
        # more than 10 × 30° off the reference
        data = c.get(f"/runs/{bad['id']}/data", params={"format": "json"}).json()["data"]
        off = np.abs(np.subtract(data["theta"], data["r"]))
        k = int(np.flatnonzero(off <= 10 * math.radians(30))[-1]) + 1
        assert 0 < k < 4999 and ran_away["k"] == k, (ran_away, k)
        assert f"ran away from t = {k * 1e-3:.4g} s" in ran_away["text"]
        listed = {r["id"]: r for r in c.get("/runs", params={"limit": 50}).json()["runs"]}
        assert listed[bad["id"]]["outcome"] == run["outcome"]
        assert listed[good["id"]]["outcome"] == []
        csv = c.get(f"/runs/{bad['id']}/data", params={"format": "csv"}).text
        head = [line for line in csv.splitlines() if line.startswith("# outcome: ")]
        assert len(head) == 1 and "u sat at the actuator's limit" in head[0], head
        assert "ran away from t = " in head[0] and "unstable, or a sign is wrong" in head[0]
        good_csv = c.get(f"/runs/{good['id']}/data", params={"format": "csv"}).text
        assert "# outcome:" not in good_csv
