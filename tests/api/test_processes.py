"""The engine in its own process, for real: the web process stopped mid-run loses nothing,
a killed engine interrupts its runs (keeping their data) and comes back, a stopped engine
resumes, and commands racing on one run are decided once (no 500, never a dropped
connection)."""

from __future__ import annotations

import asyncio
import json
import math
import os
import signal
import subprocess
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from subprocess import DEVNULL
from typing import Any

import httpx
import numpy as np
import pytest

from elab.plants import get_plant
from elab.sim import RunSpec, Square, simulate
from tests.api.server import ELAB, TLS, Server, Watcher, until
from tests.api.test_live_runs import NAMES, downloads

FLEX = get_plant("flexible_link")
SQUARE = {"kind": "square", "amplitude": math.radians(30), "period": 2.0}


def offline(duration: float) -> np.ndarray:
    res = simulate(RunSpec(FLEX, FLEX.predefined, Square(math.radians(30), 2.0), duration=duration))
    return np.column_stack([res.r, res.u, res.y, res.x])


async def follow(w: Watcher, states: set[str], timeout: float = 60) -> dict[str, Any]:
    """Receive until a status in ``states``, asking for skipped frames again."""
    deadline = time.monotonic() + timeout
    while True:
        msg = await w.next(max(0.1, deadline - time.monotonic()))
        if msg["type"] == "skipped":
            await w.conn.send(json.dumps({"type": "resume_from", "seq": msg["from_seq"]}))
        if msg["type"] == "status" and msg["state"] in states:
            return msg


def received(w: Watcher) -> int:
    return sum(len(next(iter(c.values()))) for c in w.columns.values())


async def until_async(cond: Any, timeout: float = 30) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, "not reached"
        await asyncio.sleep(0.02)


def test_the_web_process_stopped_for_2_s_mid_run_loses_no_sample(server: Server) -> None:
    with server.client() as c:
        rid = c.post(
            "/runs", json={"plant": "flexible_link", "signal": SQUARE, "duration": 6.0}
        ).json()["id"]

        async def scenario() -> Watcher:
            w = await Watcher.open(server.ws_url, rid, "?from_seq=0")
            done = asyncio.create_task(follow(w, {"finished"}))
            await until_async(lambda: received(w) >= 1000)
            assert server.proc is not None
            os.kill(server.proc.pid, signal.SIGSTOP)  # the web process, not the engine
            time.sleep(2.0)  # this thread too: nothing is read meanwhile
            os.kill(server.proc.pid, signal.SIGCONT)
            await done
            await w.conn.close()
            return w

        w = asyncio.run(scenario())
        want = offline(6.0)
        recorded = downloads(c, rid)["csv"]
        np.testing.assert_array_equal(recorded, want)  # the engine recorded every sample
        got = w.assemble(6000)  # and the watcher received every one
        for i, name in enumerate(NAMES):
            np.testing.assert_array_equal(got[name], want[:, i].astype("<f4"))


@pytest.mark.local_engine_only("the server restarts its engine (broker: test_engines_on_broker)")
def test_a_killed_engine_interrupts_its_runs_with_their_data_and_starts_again(
    server: Server,
) -> None:
    with server.client() as c:
        rid = c.post(
            "/runs", json={"plant": "flexible_link", "signal": SQUARE, "duration": 60.0}
        ).json()["id"]
        pid = server.engine_pid
        restarts = server.status()["engine"]["restarts"]  # the shared server's so far

        async def scenario() -> dict[str, Any]:
            w = await Watcher.open(server.ws_url, rid, "?from_seq=0")
            end = asyncio.create_task(follow(w, {"interrupted"}))
            await until_async(lambda: received(w) >= 1000)
            os.kill(pid, signal.SIGKILL)
            await end
            await w.conn.close()
            return end.result()

        end = asyncio.run(scenario())
        assert "SIGKILL" in end["error"]
        # the watchers were told what the recording holds: frames streamed after the
        # last commit are not part of the run (issue 24: they were, then vanished)
        info = c.get(f"/runs/{rid}").json()
        assert info["status"] == "interrupted" and "killed by SIGKILL" in info["error"]
        got = downloads(c, rid)["csv"]
        assert end["k"] == info["n_samples"] == got.shape[0]
        assert 500 <= got.shape[0] < 60_000  # what was committed (every 0.25 s)
        np.testing.assert_array_equal(got, offline(60.0)[: got.shape[0]])
        # a new engine takes over and new runs work
        until(lambda: c.get("/health").status_code == 200)
        st = server.status()["engine"]
        assert st["restarts"] == restarts + 1 and st["pid"] != pid and st["up"]
        again = c.post(
            "/runs", json={"plant": "belt_conveyor", "duration": 0.5, "pace": "fast"}
        ).json()["id"]
        until(lambda: c.get(f"/runs/{again}").json()["status"] == "finished")


@pytest.mark.local_engine_only("the server's own engine, found by its pid in /server")
def test_a_stopped_engine_is_reported_and_its_runs_complete_after_it_goes_on(
    server: Server,
) -> None:
    with server.client() as c:
        rid = c.post(
            "/runs", json={"plant": "flexible_link", "signal": SQUARE, "duration": 4.0}
        ).json()["id"]
        pid = server.engine_pid
        restarts = server.status()["engine"]["restarts"]  # the shared server's so far
        until(lambda: c.get(f"/runs/{rid}").json()["n_samples"] > 500)
        os.kill(pid, signal.SIGSTOP)
        try:
            r = until(lambda: (h := c.get("/health")).status_code == 503 and h)
            assert "has not reported" in r.json()["problems"][0]
            r = c.post(f"/runs/{rid}/pause")  # the engine cannot answer: 503, not a hang
            assert r.status_code == 503 and "did not answer" in r.json()["error"]["message"]
        finally:
            os.kill(pid, signal.SIGCONT)
        until(lambda: c.get("/health").status_code == 200)
        # the pause was decided when the engine went on: resume, then let it finish
        until(lambda: c.get(f"/runs/{rid}").json()["status"] in ("paused", "running"))
        if c.get(f"/runs/{rid}").json()["status"] == "paused":
            assert c.post(f"/runs/{rid}/resume").status_code == 200
        until(lambda: c.get(f"/runs/{rid}").json()["status"] == "finished")
        assert server.status()["engine"]["restarts"] == restarts  # it went on: not replaced


@pytest.mark.local_engine_only("the server kills its engine (on a broker: test_engines_on_broker)")
def test_an_engine_stalled_past_its_limit_is_killed_and_its_runs_say_why(tmp_path: Path) -> None:
    """Issue 24: a run ended by the stall watchdog said "killed by SIGKILL", as if someone
    had killed the engine; it now says the server did, and why."""
    srv = Server(tmp_path / "data", ELAB_ENGINE_STALL="3").start()
    try:
        with srv.client() as c:
            rid = c.post("/runs", json={"plant": "belt_conveyor", "duration": 120}).json()["id"]
            until(lambda: c.get(f"/runs/{rid}").json()["n_samples"] > 300)
            pid = srv.engine_pid
            os.kill(pid, signal.SIGSTOP)
            info = until(
                lambda: (i := c.get(f"/runs/{rid}").json())["status"] == "interrupted" and i,
                60,
            )
            assert "was killed: it sent nothing for 3 s (ELAB_ENGINE_STALL)" in info["error"]
            assert info["n_samples"] > 0  # what was committed before the stall
            until(lambda: c.get("/health").status_code == 200, 60)
            assert srv.status()["engine"]["pid"] != pid
    finally:
        srv.stop()


@pytest.fixture
def long_run(server: Server) -> str:
    with server.client() as c:
        r = c.post("/runs", json={"plant": "belt_conveyor", "duration": 600})
        assert r.status_code == 201, r.text
        return str(r.json()["id"])


def test_of_five_simultaneous_stops_one_succeeds_and_four_get_409(
    server: Server, long_run: str
) -> None:
    url = f"{server.url}/api/v1/runs/{long_run}/stop"
    with ThreadPoolExecutor(5) as ex:
        replies = list(
            ex.map(
                lambda _: httpx.post(url, timeout=30, cookies=server.cookies, verify=TLS), range(5)
            )
        )
    assert sorted(r.status_code for r in replies) == [200, 409, 409, 409, 409]
    for r in replies:
        if r.status_code == 409:
            assert "has ended (stopped)" in r.json()["error"]["message"], r.text
    with server.client() as c:
        for action in ("pause", "resume", "stop"):
            r = c.post(f"/runs/{long_run}/{action}")
            assert r.status_code == 409 and "has ended" in r.json()["error"]["message"]
        r = c.post(f"/runs/{long_run}/params", json={"signal": {"kind": "step", "amplitude": 0.1}})
        assert r.status_code == 409


def test_commands_racing_over_rest_and_the_websocket_keep_the_connection(
    server: Server, long_run: str
) -> None:
    async def scenario() -> list[dict[str, Any]]:
        w = await Watcher.open(server.ws_url, long_run, as_=server)
        async with httpx.AsyncClient(base_url=server.url + "/api/v1", cookies=server.cookies) as c:
            sends = [
                w.conn.send(json.dumps({"type": t}))
                for t in ("pause", "stop", "resume", "stop", "pause")
            ]
            rest = [c.post(f"/runs/{long_run}/{a}") for a in ("stop", "pause", "stop")]
            results = await asyncio.gather(*sends, *rest)
        codes = [r.status_code for r in results[5:]]
        assert set(codes) <= {200, 409}, codes
        msgs: list[dict[str, Any]] = []
        while not any(m["type"] == "status" and m["state"] == "stopped" for m in msgs):
            m = await w.next()
            if m["type"] != "frame":
                msgs.append(m)
        await w.conn.send(json.dumps({"type": "pause"}))  # after the end: an error, kept
        while (m := await w.next())["type"] != "error":
            pass
        msgs.append(m)
        await w.conn.close()
        return msgs

    msgs = asyncio.run(scenario())
    assert msgs[-1]["code"] == "conflict" and "has ended" in msgs[-1]["message"]
    assert [m for m in msgs if m["type"] == "status" and m["state"] == "stopped"]


def _fork_server_tree(web: int) -> list[int]:
    """The fork server the web process ``web`` started and every process forked from it
    (the engine, the job workers), from /proc."""
    parents: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue  # ended meanwhile
        parents[int(stat.parent.name)] = int(fields[1])
    roots = [
        pid for pid, parent in parents.items() if parent == web and b"forkserver" in _cmdline(pid)
    ]
    tree = list(roots)
    for pid in tree:  # breadth first: the list grows as it is walked
        tree += [child for child, parent in parents.items() if parent == pid]
    return tree


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


@pytest.mark.local_engine_only("the server starts its engine itself")
def test_a_run_asked_for_while_the_engine_starts_waits_briefly_then_is_told_to_retry(
    tmp_path: Path,
) -> None:
    """The web process serves before its engine is up (the engine starts in the
    background): a run asked for then waits as long as for any answer
    (``ELAB_ENGINE_TIMEOUT``, 0.3 s here), then is 503 "starting" with a Retry-After,
    never a hang or a 500; once /health is 200 the same request starts the run. The
    engine is held back for sure, on any machine: the fork server it comes from (and
    whatever it forked already) is stopped (SIGSTOP) as soon as the web process serves,
    and let go after the 503."""
    srv = Server(tmp_path / "data", ELAB_ENGINE_TIMEOUT="0.3", ELAB_RIG="none")
    srv.log_path.parent.mkdir(parents=True, exist_ok=True)
    with srv.log_path.open("ab") as log:
        srv.proc = subprocess.Popen(
            [ELAB, "serve", "--port", str(srv.port)], env=srv.env, stdout=DEVNULL, stderr=log
        )
    stopped: list[int] = []
    try:
        body = {"plant": "flexible_link", "duration": 1.0, "pace": "fast"}
        with httpx.Client(base_url=srv.url + "/api/v1", timeout=30, verify=TLS) as c:

            def health() -> int | None:
                try:
                    return c.get("/health").status_code
                except httpx.TransportError:
                    return None  # not serving yet

            # the fork server starts before the web app is imported (elab serve)
            web = srv.proc.pid
            forked = until(lambda: _fork_server_tree(web), 60, 0.01)
            for pid in forked:
                os.kill(pid, signal.SIGSTOP)
                stopped.append(pid)
            until(health, 120, 0.02)
            said = c.get("/health")
            if said.status_code == 503:  # the engine was not up before the stop
                assert said.json()["status"] == "unavailable", said.text
                r = c.post("/runs", json=body)
                assert r.status_code == 503, r.text
                assert "starting" in r.json()["error"]["message"], r.text
                assert float(r.headers["retry-after"]) > 0
            else:  # it was up already: the stop came too late to show the wait
                assert said.status_code == 200, said.text
                pytest.fail("the engine was up before the web process served")
            for pid in stopped:
                os.kill(pid, signal.SIGCONT)
            stopped.clear()
            until(lambda: health() == 200, 120)

            def started() -> httpx.Response | None:
                x = c.post("/runs", json=body)
                return None if x.status_code == 503 else x

            started_run = until(started, 60)
            assert started_run.status_code == 201, started_run.text
    finally:
        for pid in stopped:
            os.kill(pid, signal.SIGCONT)
        srv.stop()


def test_a_change_racing_a_stop_is_answered_as_the_runs_record_says(
    server: Server, long_run: str
) -> None:
    """Parameter changes sent with a stop: each is applied (200) or refused because the
    run has ended (409 naming its status), and a run refused as ended reads as ended at
    once (under two CPU hogs a change that reached the engine after the stop had got
    the engine's bare refusal while the run still read "running")."""
    base = f"{server.url}/api/v1/runs/{long_run}"
    gains = {"controller": {"kind": "pid", "Kp": 2.0, "Ki": 0.5}}

    def change(i: int) -> httpx.Response:
        if i == 3:
            return httpx.post(f"{base}/stop", timeout=30, cookies=server.cookies, verify=TLS)
        return httpx.post(
            f"{base}/params", json=gains, timeout=30, cookies=server.cookies, verify=TLS
        )

    with ThreadPoolExecutor(8) as ex:
        replies = list(ex.map(change, range(8)))
    assert replies[3].status_code == 200, replies[3].text
    for r in replies:
        assert r.status_code in (200, 409), r.text
        if r.status_code == 409:
            assert "has ended (stopped)" in r.json()["error"]["message"], r.text
    with server.client() as c:
        assert c.get(f"/runs/{long_run}").json()["status"] == "stopped"
