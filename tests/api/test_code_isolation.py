"""A student's Python controller slows only its own run (issue 24): a controller that is
fast in its upload trial and slow in the run (9 steps of 10 take about 20 ms, never 10 in a
row) ran on the thread that steps everyone, and another identity's real-time run dropped
from 1000 to 0-256 samples a second. Each code run now has a thread of its own."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from elab.controllers.sandbox import available
from tests.api.server import Server, until
from tests.api.test_code_controllers import upload

pytestmark = pytest.mark.skipif(available() is not None, reason=str(available()))

# slow only at a sample time of 2 ms: its upload trial runs at the plant's 1 ms
SLOW_IN_THE_RUN = """
class Controller:
    def reset(self, params):
        self.slow = params["Ts"] == 0.002
        self.n = 0

    def step(self, t, y, r):
        self.n += 1
        if self.slow and self.n % 10:
            s = 0
            for i in range(400_000):  # about 20 ms
                s += i
        return 0.0
"""


@pytest.mark.local_engine_only("both slow runs on one engine, its timing in /server")
def test_slow_code_runs_delay_nobody_else(tmp_path: Path) -> None:
    # a budget that lets the slow controller run on (by default it would fail in 0.2 s)
    srv = Server(tmp_path / "data", ELAB_CODE_BUDGET="1000").start()
    try:
        with srv.stranger() as student, srv.stranger() as bystander:
            up = upload(student, SLOW_IN_THE_RUN)
            assert up["report"]["problems"] == [], up["report"]  # fast in its trial
            mine = bystander.post("/runs", json={"plant": "flexible_link", "duration": 12})
            assert mine.status_code == 201, mine.text
            slow = [
                student.post(
                    "/runs",
                    json={
                        "plant": "flexible_link",
                        "controller_id": up["id"],
                        "Ts": 0.002,
                        "duration": 30,
                    },
                ).json()["id"]
                for _ in range(2)
            ]
            rid = mine.json()["id"]
            until(lambda: srv.status()["stepper"]["code_clock_lag_max_ms"] > 1000, 60)
            timing = srv.status()["stepper"]
            assert timing["code_runs"] == 2, [student.get(f"/runs/{r}").json() for r in slow]
            assert timing["late_p99_ms"] <= 5.0, timing  # the shared thread keeps time
            # its runs' clocks too: with the slow code on the shared thread they fell
            # seconds behind (256 samples a second of 1000); a machine busy with three
            # test workers held one back by 30 ms once, which is the machine, not the code
            assert timing["clock_lag_max_ms"] <= 250.0, timing
            done = until(lambda: (i := bystander.get(f"/runs/{rid}").json())["finished_at"] and i)
            assert (done["status"], done["n_samples"]) == ("finished", 12_000)
            # 1000 samples a second: the run took its 12 s (and the store's last commit)
            assert done["finished_at"] - done["started_at"] < 12 + 2.0, done
            behind = [student.get(f"/runs/{r}").json() for r in slow]
            # the slow runs are their own clocks' problem: those still going are far behind
            # (one may also have ended by its own slowness on a loaded machine)
            behind = [b for b in behind if b["status"] == "running"]
            # each slow run is its own clock's problem: far behind the 30 s it would be at
            elapsed = time.time() - min((b["started_at"] for b in behind), default=0.0)
            assert all(b["n_samples"] * 0.002 < elapsed / 2 for b in behind), (behind, elapsed)
            for b in behind:
                assert student.post(f"/runs/{b['id']}/stop").status_code in (200, 409)
            until(lambda: srv.status()["stepper"]["code_runs"] == 0)
    finally:
        srv.stop()
