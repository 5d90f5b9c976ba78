"""Each plant's lesson (issue 27: a presenter steps through the chapter's runs with one
key): every step, as ``GET /plants/{id}`` gives it, starts as a run, and the run does
what the step's text tells the class: the plant alone and the arbitrary gain go wrong in
the way it names (outcome marks), the designed controller ends with nothing to say."""

from __future__ import annotations

from typing import Any

import pytest

from tests.api.server import Server, until

#: per plant, the outcome marks of each step's run, in order
EXPECTED = {
    "flexible_link": [[], ["saturated", "ran_away"], []],
    "double_pendulum": [["left_range"], ["beyond_actuator", "left_range"], ["beyond_actuator"]],
    "belt_conveyor": [[], [], []],
}


@pytest.mark.parametrize("plant", sorted(EXPECTED))
def test_every_lesson_step_runs_and_goes_as_its_text_says(server: Server, plant: str) -> None:
    with server.client() as c:
        lesson = c.get(f"/plants/{plant}").json()["lesson"]
        assert lesson[0]["title"] == "The plant alone"
        assert len(lesson) == len(EXPECTED[plant]) == 3
        got = []
        for step in lesson:
            body: dict[str, Any] = {
                "plant": plant,
                "experiment": "analysis",
                "pace": "fast",
                **{k: step[k] for k in ("controller", "signal", "duration")},
            }
            if step["x0"] is not None:
                body["x0"] = step["x0"]
            r = c.post("/runs", json=body)
            assert r.status_code == 201, r.text
            rid = r.json()["id"]
            run = until(
                lambda rid=rid: (
                    (j := c.get(f"/runs/{rid}").json())["finished_at"]
                    and j["outcome"] is not None
                    and j
                ),
                120,
            )
            assert run["status"] == "finished", run
            got.append(sorted(m["kind"] for m in run["outcome"]))
        assert got == [sorted(e) for e in EXPECTED[plant]], got
