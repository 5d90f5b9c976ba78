"""A hypothesis state machine drives a real server with random interleavings of create,
pause, resume, stop and parameter changes (over REST and over websockets, as the runs'
owner), a stranger trying the same on them, watchers that join and vanish, and time
passing, checked against a model of the run state machine: no 500, nothing hangs, every
answer agrees with the model, every stranger's attempt is refused and changes nothing,
and at the end every recording is
complete and equal to the offline simulation with the recorded parameter changes, and every
watcher still connected received every sample."""

from __future__ import annotations

import json
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import httpx
import msgpack
import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, settings
from hypothesis import strategies as st
from hypothesis.stateful import Bundle, RuleBasedStateMachine, invariant, rule
from websockets.sync.client import ClientConnection, connect

from elab.laws import StateFeedback
from elab.plants import get_plant
from elab.sim import RunSpec, Samples, Simulation, Square, Step
from tests.api.server import TLS, Server, identity_of

FLEX = get_plant("flexible_link")
SQUARE = {"kind": "square", "amplitude": math.radians(20), "period": 1.0}
GAINS = [[20, -93.5614, 3.3621, 0.9623], [12, -60, 2.5, 0.8], [25, -110, 4, 1.1]]
LIVE, ENDED = {"running", "paused"}, {"finished", "stopped"}


@dataclass
class Run:
    id: str
    duration: float
    state: str = "running"  # the model's: running | paused | ended


@dataclass(eq=False)
class Watch:
    run: Run
    conn: ClientConnection
    frames: dict[int, dict[str, np.ndarray]] = field(default_factory=dict)
    statuses: list[str] = field(default_factory=list)
    errors: list[dict[str, Any]] = field(default_factory=list)
    closed_by_us: bool = False
    failure: BaseException | None = None

    def read(self) -> None:
        try:
            for raw in self.conn:
                msg = msgpack.unpackb(raw)
                if msg["type"] == "frame":
                    cols = {k: np.frombuffer(v, "<f4") for k, v in msg["columns"].items()}
                    self.frames[msg["k0"]] = cols
                elif msg["type"] == "skipped":
                    self.conn.send(json.dumps({"type": "resume_from", "seq": msg["from_seq"]}))
                elif msg["type"] == "status":
                    self.statuses.append(msg["state"])
                elif msg["type"] == "error":
                    self.errors.append(msg)
        except Exception as exc:  # the connection closed: by us, or a failure to report
            if not self.closed_by_us:
                self.failure = exc


class Lab(RuleBasedStateMachine):
    server: Server  # set by the test

    runs = Bundle("runs")
    watches = Bundle("watches")

    def __init__(self) -> None:
        super().__init__()
        api = self.server.url + "/api/v1"
        self.c = httpx.Client(base_url=api, timeout=30, verify=TLS)  # the owner
        self.stranger = httpx.Client(base_url=api, timeout=30, verify=TLS)
        self.all_runs: list[Run] = []
        self.all_watches: list[Watch] = []

    # -- helpers ----------------------------------------------------------------
    def call(self, method: str, path: str, **kw: Any) -> httpx.Response:
        r = self.c.request(method, path, **kw)  # a hang fails by the client's timeout
        assert r.status_code < 500, f"{method} {path}: {r.status_code} {r.text[:300]}"
        return r

    def server_state(self, run: Run) -> str:
        return str(self.call("GET", f"/runs/{run.id}").json()["status"])

    def settle(self, run: Run, r: httpx.Response, want: str) -> None:
        """A control answer: 200 in the wanted state, or 409 because the run cannot."""
        if r.status_code == 200:
            assert run.state != "ended", f"{run.id} ended, yet {want} succeeded"
            assert r.json()["status"] == want
            run.state = "ended" if want in ENDED else want
            return
        assert r.status_code == 409, r.text
        now = self.server_state(run)
        if now in ENDED:
            run.state = "ended"
        else:
            assert now == run.state, f"409 but the run is {now} (model: {run.state})"
            assert {"paused": "running", "running": "paused"}.get(now) != want

    # -- rules ------------------------------------------------------------------------
    @rule(target=runs, duration=st.sampled_from([0.8, 1.5, 3.0]))
    def create(self, duration: float) -> Run:
        r = self.call(
            "POST", "/runs", json={"plant": "flexible_link", "signal": SQUARE, "duration": duration}
        )
        assert r.status_code == 201, r.text
        run = Run(r.json()["id"], duration)
        self.all_runs.append(run)
        return run

    @rule(run=runs, action=st.sampled_from(["pause", "resume", "stop"]))
    def control_over_rest(self, run: Run, action: str) -> None:
        want = {"pause": "paused", "resume": "running", "stop": "stopped"}[action]
        self.settle(run, self.call("POST", f"/runs/{run.id}/{action}"), want)

    @rule(watch=watches, action=st.sampled_from(["pause", "resume", "stop"]))
    def control_over_websocket(self, watch: Watch, action: str) -> None:
        if watch.closed_by_us:
            return
        before = len(watch.statuses) + len(watch.errors)
        watch.conn.send(json.dumps({"type": action}))
        deadline = time.monotonic() + 10
        while len(watch.statuses) + len(watch.errors) == before and watch.run.state != "ended":
            assert time.monotonic() < deadline, "no answer to a websocket command"
            assert watch.failure is None, watch.failure
            time.sleep(0.01)
            if self.server_state(watch.run) in ENDED:
                break
        now = self.server_state(watch.run)
        watch.run.state = "ended" if now in ENDED else now

    @rule(
        run=runs,
        action=st.sampled_from(["pause", "resume", "stop", "params", "delete"]),
        over=st.sampled_from(["rest", "websocket"]),
    )
    def a_stranger_tries(self, run: Run, action: str, over: str) -> None:
        """Refused, whatever the run's state; the invariant checks nothing changed."""
        if over == "rest" or action == "delete":
            method, path, body = "POST", f"/runs/{run.id}/{action}", None
            if action == "params":
                body = {"controller": {"kind": "state_feedback", "K": GAINS[1]}}
            if action == "delete":
                method, path = "DELETE", f"/runs/{run.id}"
            r = self.stranger.request(method, path, json=body)
            assert r.status_code == 403, r.text
            return
        message: dict[str, Any] = {"type": action}
        if action == "params":
            message = {
                "type": "set_params",
                "controller": {"kind": "state_feedback", "K": GAINS[1]},
            }
        with connect(
            f"{self.server.ws_url}/api/v1/runs/{run.id}/stream",
            subprotocols=["elab.v1"],  # type: ignore[list-item]
            additional_headers=identity_of(self.stranger),
            max_size=None,
        ) as conn:
            conn.send(json.dumps(message))
            while (msg := msgpack.unpackb(conn.recv(timeout=10)))["type"] != "error":
                assert msg["type"] != "status" or msg["state"] in ENDED, msg
            assert msg["code"] == "forbidden", msg

    @rule(run=runs, gains=st.sampled_from(GAINS), step=st.booleans())
    def change_params(self, run: Run, gains: list[float], step: bool) -> None:
        body: dict[str, Any] = {"controller": {"kind": "state_feedback", "K": gains}}
        if step:
            body["signal"] = {"kind": "step", "amplitude": math.radians(10)}
        r = self.call("POST", f"/runs/{run.id}/params", json=body)
        if r.status_code == 200:
            assert run.state != "ended"
        else:
            assert r.status_code == 409, r.text
            assert self.server_state(run) in ENDED
            run.state = "ended"

    @rule(target=watches, run=runs)
    def watch(self, run: Run) -> Watch:
        conn = connect(
            f"{self.server.ws_url}/api/v1/runs/{run.id}/stream?from_seq=0",
            subprotocols=["elab.v1"],
            additional_headers=identity_of(self.c),  # the owner's: its commands count
            max_size=None,  # type: ignore[list-item]
            legacy=True,
        )  # closed in teardown, not by a with block
        w = Watch(run, conn)
        assert msgpack.unpackb(conn.recv(timeout=10))["type"] == "hello"
        threading.Thread(target=w.read, daemon=True).start()
        self.all_watches.append(w)
        return w

    @rule(watch=watches)
    def vanish(self, watch: Watch) -> None:
        watch.closed_by_us = True
        watch.conn.socket.close()  # no close handshake: the client is simply gone

    @rule(seconds=st.sampled_from([0.05, 0.3, 1.0]))
    def time_passes(self, seconds: float) -> None:
        time.sleep(seconds)

    @invariant()
    def the_server_agrees_with_the_model(self) -> None:
        for run in self.all_runs:
            now = self.server_state(run)
            if run.state == "paused":
                assert now == "paused", f"{run.id}: {now}, model paused"
            elif run.state == "running":
                assert now in {"running", "finished"}, f"{run.id}: {now}, model running"
                if now == "finished":
                    run.state = "ended"
            else:
                assert now in ENDED, f"{run.id}: {now}, model ended"
        for w in self.all_watches:
            assert w.failure is None, w.failure
            assert all(e["code"] != "forbidden" for e in w.errors), w.errors

    # -- the end ------------------------------------------------------------------------
    def teardown(self) -> None:
        try:
            for run in self.all_runs:
                if run.state != "ended":
                    self.settle(run, self.call("POST", f"/runs/{run.id}/stop"), "stopped")
            for run in self.all_runs:
                self.check_recording(run)
            for w in self.all_watches:
                if not w.closed_by_us:
                    self.check_watcher(w)
        finally:
            for w in self.all_watches:
                w.closed_by_us = True
                w.conn.close()
            self.c.close()
            self.stranger.close()

    def check_recording(self, run: Run) -> None:
        info = self.call("GET", f"/runs/{run.id}").json()
        n = info["n_samples"]
        assert info["status"] in ENDED and (info["status"] == "stopped" or n == info["n_planned"])
        data = self.call("GET", f"/runs/{run.id}/data", params={"format": "json"}).json()
        got = np.column_stack([data["data"][c["name"]] for c in info["channels"]])
        assert got.shape[0] == n
        np.testing.assert_array_equal(got, offline(run.duration, info["param_changes"], n))

    def check_watcher(self, w: Watch) -> None:
        deadline = time.monotonic() + 20
        while not set(w.statuses) & ENDED:  # the final status comes after every frame
            assert time.monotonic() < deadline and w.failure is None, (w.statuses, w.failure)
            time.sleep(0.02)
        info = self.call("GET", f"/runs/{w.run.id}").json()
        names = [c["name"] for c in info["channels"]]
        while True:  # frames asked again after a skip may still be on their way
            seen = np.zeros(info["n_samples"], dtype=bool)
            for k0, cols in w.frames.items():
                seen[k0 : k0 + len(cols[names[0]])] = True
            if seen.all() or time.monotonic() > deadline:
                break
            time.sleep(0.05)
        assert seen.all(), f"watcher of {w.run.id}: {np.count_nonzero(~seen)} samples missing"


def offline(duration: float, changes: list[dict[str, Any]], n: int) -> np.ndarray:
    """The run computed offline with its parameter changes at their recorded samples."""
    sim = Simulation(
        RunSpec(FLEX, FLEX.predefined, Square(math.radians(20), 1.0), duration=duration)
    )
    parts = []
    for change in sorted(changes, key=lambda c: c["k"]):
        parts.append(sim.advance(change["k"] - sim.k))
        p = change["params"]
        if "controller" in p:
            sim.set_law(StateFeedback(tuple(p["controller"]["K"]), "velocity_filters"))
        if "signal" in p:
            sim.set_reference(Step(p["signal"]["amplitude"]))
    parts.append(sim.advance(n - sim.k))
    kept = [x for x in parts if x.n]
    if not kept:
        return np.zeros((0, 2 + FLEX.ny + FLEX.nx))
    res = Samples.concatenate(kept)
    return np.column_stack([res.r, res.u, res.y, res.x])


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_random_interleavings_keep_the_run_state_machine_and_every_sample(server: Server) -> None:
    Lab.server = server
    # no shrinking: each step runs against a live server, and a failure prints its steps
    run = settings(
        max_examples=6,
        stateful_step_count=14,
        deadline=None,
        phases=[Phase.explicit, Phase.reuse, Phase.generate],
        suppress_health_check=list(HealthCheck),
    )(Lab).TestCase
    run().runTest()
    assert "Traceback" not in server.log, server.log[-6000:]
