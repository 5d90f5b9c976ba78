"""A hypothesis state machine over the rig's queue through a real server and its emulated
rig: two students and an instructor join, leave, arm, start runs, stop them, press the
emergency stop and take over, and the web server restarts, in any order. After every step:
never two drivers (as each user sees it), never two runs live on the rig, and the run
live on the rig is the one the queue seated (the engine follows the queue within
seconds). No answer is a 500."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import httpx
import pytest
from hypothesis import HealthCheck, Phase, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from tests.api.server import Server, until
from tests.api.test_access import instructor, instructors_file

RUN = {
    "plant": "flexible_link",
    "mode": "rig",
    "duration": 20.0,
    "signal": {"kind": "square", "amplitude": math.radians(15), "period": 2.0},
}
OK = {200, 201, 204, 403, 409, 422, 503}  # refusals are fine; a 500 never is


class RigMachine(RuleBasedStateMachine):
    server: Server

    def __init__(self) -> None:
        super().__init__()
        srv = type(self).server
        for user in ("a", "b"):
            setattr(self, user, srv.visitor())
        self.prof = instructor(srv)  # signed in once (the session outlives a restart)
        self.restarts = 0

    def call(self, who: str, method: str, path: str, **kw: Any) -> httpx.Response:
        # a cap past the server's 60 s for a rig trial (ELAB_TRIAL_TIMEOUT): a run's first
        # trial imports python-control on a thread, seconds beside two CPU hogs
        kw = {"timeout": 120, **kw}
        if who == "prof":
            r = self.prof.request(method, path, **kw)
        else:
            with getattr(self, who).client() as c:
                r = c.request(method, path, **kw)
        assert r.status_code in OK, (method, path, r.status_code, r.text)
        return r

    @rule(who=st.sampled_from(["a", "b", "prof"]))
    def join(self, who: str) -> None:
        self.call(who, "POST", "/rig/queue")

    @rule(who=st.sampled_from(["a", "b", "prof"]))
    def leave(self, who: str) -> None:
        self.call(who, "DELETE", "/rig/queue")

    @rule(who=st.sampled_from(["a", "b", "prof"]))
    def arm(self, who: str) -> None:
        self.call(who, "POST", "/rig/arm")

    @rule(who=st.sampled_from(["a", "b", "prof"]))
    def start(self, who: str) -> None:
        self.call(who, "POST", "/runs", json=RUN)

    @rule(who=st.sampled_from(["a", "b", "prof"]))
    def stop(self, who: str) -> None:
        run_id = self.call(who, "GET", "/rig").json()["run_id"]
        if run_id is not None:
            self.call(who, "POST", f"/runs/{run_id}/stop")

    @rule(who=st.sampled_from(["a", "b", "prof"]))
    def estop(self, who: str) -> None:
        self.call(who, "POST", "/rig/estop")

    @rule()
    def take_over(self) -> None:
        self.call("prof", "POST", "/rig/takeover")

    def teardown(self) -> None:
        self.prof.close()

    @rule(who=st.sampled_from(["a", "b", "prof"]))
    def drive(self, who: str) -> None:
        """Join, arm and start at once, as the page does when it is one's turn."""
        self.call(who, "POST", "/rig/queue")
        self.call(who, "POST", "/rig/arm")
        self.call(who, "POST", "/runs", json=RUN)

    @precondition(lambda self: self.restarts < 1)  # a restart costs seconds: one per example
    @rule()
    def restart_the_web_server(self) -> None:
        self.restarts += 1
        self.server.stop()
        self.server.start()
        until(lambda: (self.server.status().get("rig") or {}).get("connected"), 60)

    @invariant()
    def one_driver_and_the_seated_run_only(self) -> None:
        views = {who: self.call(who, "GET", "/rig").json() for who in ("a", "b", "prof")}
        assert sum(v["you"]["driving"] for v in views.values()) <= 1, views

        def agreed() -> bool:
            q = self.call("a", "GET", "/rig").json()
            live = self.call("a", "GET", "/runs?live=true").json()["runs"]
            on_rig = [r["id"] for r in live if r["mode"] == "rig"]
            assert len(on_rig) <= 1, on_rig
            return on_rig in ([], [q["run_id"]])

        until(agreed, 30, every=0.2)


@pytest.fixture(scope="module")
def rig_server(tmp_path_factory: pytest.TempPathFactory) -> Any:
    data = tmp_path_factory.mktemp("rig-machine")
    srv = Server(
        data,
        ELAB_RIG="emulator",
        ELAB_RIG_WATCHDOG="200",
        ELAB_INSTRUCTORS=str(instructors_file(Path(data).parent)),
    ).start()
    try:
        until(lambda: (srv.status().get("rig") or {}).get("connected"), 60)
        yield srv
    finally:
        srv.stop()


def test_the_rig_queue_never_has_two_drivers_through_restarts(rig_server: Server) -> None:
    RigMachine.server = rig_server
    run = settings(
        max_examples=2,
        stateful_step_count=10,
        deadline=None,
        phases=[Phase.generate],
        suppress_health_check=list(HealthCheck),
    )(RigMachine).TestCase
    run().runTest()
    assert "Traceback" not in rig_server.log, rig_server.log[-6000:]
