"""The rig through the server (``ELAB_RIG=emulator``: the server starts ``elab
rig-emulator`` as a process of its own and a rig engine process drives it): a run in mode
``rig`` streams live and records like a simulation's, the server says what the rig is
(emulated) and how fast its loop answers, a rig run cannot go fast or run twice at once,
and a killed host loop leaves the motor at 0 V (the emulator's watchdog) and the run
ended with a reason. A server without a rig refuses mode ``rig`` naming ``ELAB_RIG``."""

from __future__ import annotations

import asyncio
import math
import os
import signal
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

from tests.api.server import Server, Watcher, until

RIG_RUN = {
    "plant": "flexible_link",
    "mode": "rig",
    "duration": 2.0,
    "signal": {"kind": "square", "amplitude": math.radians(20), "period": 2.0},
}


def call(srv: Server, method: str, path: str, **kw: Any) -> httpx.Response:
    with srv.client() as c:
        return c.request(method, path, **kw)


def start(srv: Server, **body: object) -> dict[str, Any]:
    """Start a rig run, retrying as a client would: after a run the rig settles and
    re-zeroes first (409 until then), and a rig reconnecting is 503 until it answers."""

    def attempt() -> httpx.Response | None:
        r = call(srv, "POST", "/runs", json={**RIG_RUN, **body})
        settling = r.status_code == 409 and "settling" in r.text
        return None if settling or r.status_code == 503 else r

    r = until(attempt, 60, every=0.2)
    assert r.status_code == 201, r.text
    return r.json()  # type: ignore[no-any-return]


@pytest.fixture(scope="module")
def srv(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    # a lenient watchdog: beside two CPU hogs the test machine's rig engine can wait
    # longer than 5 ms for a CPU (docs/operations.md, ELAB_RIG_WATCHDOG)
    server = Server(
        tmp_path_factory.mktemp("rig"), ELAB_RIG="emulator", ELAB_RIG_WATCHDOG="200"
    ).start()
    try:
        until(lambda: (server.status().get("rig") or {}).get("connected"), 60)
        yield server
    finally:
        server.stop()


def test_a_rig_run_streams_live_and_records_every_sample(srv: Server) -> None:
    rig = srv.status()["rig"]
    assert rig["emulated"] and rig["rig_id"].startswith("emulator")
    modes = {p["id"]: p["modes"] for p in call(srv, "GET", "/plants").json()}
    assert modes["flexible_link"] == ["simulation", "rig"]
    assert modes["belt_conveyor"] == ["simulation"]  # the rig is the flexible link's
    run = start(srv)
    assert run["mode"] == "rig" and [c["name"] for c in run["channels"]][:4] == [
        "r",
        "u",
        "theta",
        "alpha",
    ]

    async def watch() -> dict[str, np.ndarray]:
        w = await Watcher.open(srv.ws_url, run["id"], "?from_seq=0", as_=srv)
        try:
            end = await w.until_status({"finished", "failed", "stopped"}, 60)
            assert end["state"] == "finished", end
            return w.assemble(2000)
        finally:
            await w.conn.close()

    cols = asyncio.run(watch())
    # the square's first half-period: θ follows the reference +20° (within 4°)
    k = slice(800, 1000)
    assert abs(np.degrees(np.mean(cols["theta"][k] - cols["r"][k]))) < 4.0
    csv = call(srv, "GET", f"/runs/{run['id']}/data?format=csv")
    assert csv.status_code == 200 and "mode: rig" in csv.text
    st = srv.status()["rig"]
    assert st["samples"] >= 2000 and st["latency_p99_us"] is not None


def test_a_rig_run_goes_at_the_rigs_clock_one_at_a_time(srv: Server) -> None:
    r = call(srv, "POST", "/runs", json={**RIG_RUN, "pace": "fast"})
    assert r.status_code == 422 and r.json()["error"]["field"] == "pace"
    r = call(srv, "POST", "/runs", json={**RIG_RUN, "plant": "belt_conveyor"})
    assert r.status_code == 422 and r.json()["error"]["field"] == "mode"
    first = start(srv, duration=30.0)
    assert call(srv, "GET", f"/runs/{first['id']}").json()["status"] == "running"
    second = call(srv, "POST", "/runs", json=RIG_RUN)
    assert second.status_code == 409 and "one run at a time" in second.text
    stop = call(srv, "POST", f"/runs/{first['id']}/stop")
    assert stop.status_code == 200 and stop.json()["status"] == "stopped"


def test_a_killed_host_loop_ends_its_run_and_the_rig_stops(srv: Server) -> None:
    run = start(srv, duration=30.0)
    until(lambda: call(srv, "GET", f"/runs/{run['id']}").json()["n_samples"] > 500, 30)
    os.kill(srv.status()["rig"]["engine"]["pid"], signal.SIGKILL)

    def ended_run() -> dict[str, Any] | None:
        j: dict[str, Any] = call(srv, "GET", f"/runs/{run['id']}").json()
        return None if j["status"] == "running" else j

    ended = until(ended_run, 30)
    assert ended["status"] == "interrupted" and ended["error"], ended
    # what it committed is kept (a killed engine loses at most its flush interval, 0.25 s)
    assert ended["n_samples"] > 500 - 300
    # the engine comes back and connects to the rig again (the emulator took the motor to
    # 0 V and dropped the lost host, so it accepts the new one)
    until(lambda: srv.status()["rig"]["connected"], 60)


def test_a_server_without_a_rig_says_how_to_get_one(tmp_path: Path) -> None:
    server = Server(tmp_path).start()
    try:
        assert server.status()["rig"] is None
        with server.client() as c:
            assert c.get("/plants/flexible_link").json()["modes"] == ["simulation"]
            r = c.post("/runs", json=RIG_RUN)
        assert r.status_code == 422 and "ELAB_RIG" in r.json()["error"]["message"]
    finally:
        server.stop()


def test_a_killed_emulator_fails_its_run_says_so_and_comes_back(srv: Server) -> None:
    run = start(srv, duration=30.0)
    until(lambda: call(srv, "GET", f"/runs/{run['id']}").json()["n_samples"] > 300, 30)
    assert srv.proc is not None
    found = subprocess.run(
        ["pgrep", "-P", str(srv.proc.pid), "-f", "rig-emulator"],
        capture_output=True,
        text=True,
        check=True,
    )
    os.kill(int(found.stdout.split()[0]), signal.SIGKILL)

    def ended_run() -> dict[str, Any] | None:
        j: dict[str, Any] = call(srv, "GET", f"/runs/{run['id']}").json()
        return None if j["status"] == "running" else j

    ended = until(ended_run, 30)
    assert ended["status"] == "failed" and "rig" in ended["error"], ended
    assert ended["n_samples"] > 0
    # the server starts the emulator again on the same port and the engine reconnects;
    # meanwhile /health may say the rig is not connected (degraded, not down)
    health = call(srv, "GET", "/health").json()
    assert health["status"] in ("ok", "degraded")
    assert start(srv)["status"] == "running"  # once the rig answers again


def test_a_rig_that_does_not_answer_degrades_health_and_only_rig_runs(tmp_path: Path) -> None:
    server = Server(tmp_path, ELAB_RIG="127.0.0.1:9").start()  # the discard port: refused
    try:

        def rig_problem() -> list[str] | None:
            h = httpx.get(server.url + "/api/v1/health", timeout=30).json()
            return h["problems"] if h["status"] == "degraded" else None

        problems = until(rig_problem, 30)
        assert any("rig is not connected" in p for p in problems), problems
        with server.client() as c:
            r = c.post("/runs", json=RIG_RUN)
            assert r.status_code == 503 and "not connected" in r.text
            sim = c.post("/runs", json={"plant": "flexible_link", "duration": 1.0})
            assert sim.status_code == 201
    finally:
        server.stop()
