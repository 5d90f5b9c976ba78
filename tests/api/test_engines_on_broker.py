"""Simulation engines of their own on a Redis broker (``ELAB_REDIS_URL``, ``elab engine``):
a real redis-server, real engine processes beside a real ``elab serve``, each test a server
of its own (``make test-cluster`` runs the whole API suite this way)."""

from __future__ import annotations

import asyncio
import os
import signal
import sqlite3
import subprocess
import time
from collections import Counter
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

from tests.api.server import ELAB, TLS, Server, Watcher, until
from tests.api.test_live_runs import NEW_K, NEW_SQUARE, SQUARE, _received, downloads, offline
from tests.api.test_processes import until_async
from tests.redis_server import RedisServer

LONG = {"plant": "flexible_link", "signal": SQUARE, "duration": 60.0}


def on_broker(tmp_path: Path, broker: RedisServer, **env: str) -> Server:
    return Server(
        tmp_path / "data", **{"ELAB_REDIS_URL": broker.url(), "ELAB_ENGINE_STALL": "5", **env}
    )


def engines_of(srv: Server) -> dict[str, str]:
    """Each run's engine, as the store recorded it (its own record; the API does not say)."""
    url = srv.env.get("ELAB_DATABASE_URL")
    if url is not None:
        import psycopg

        with psycopg.connect(url) as conn:
            return dict(conn.execute("SELECT id, engine FROM runs").fetchall())
    path = srv.data / "elab.sqlite3"
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as db:
        return dict(db.execute("SELECT id, engine FROM runs").fetchall())


def engine_pid(srv: Server, name: str) -> int:
    i = int(name.rsplit("-", 1)[1])
    proc = srv.engines[i]
    assert proc is not None
    return proc.pid


def a_second_into_a_long_run(srv: Server, c: httpx.Client) -> tuple[str, str, int]:
    """A 60 s run started and 1,000 samples in: its id, its engine and that one's pid."""
    rid = c.post("/runs", json=LONG).json()["id"]
    until(lambda: c.get(f"/runs/{rid}").json()["n_samples"] >= 1000)
    name = engines_of(srv)[rid]
    return rid, name, engine_pid(srv, name)


def reported(srv: Server, name: str, not_pid: int) -> bool:
    """The web process hears engine ``name`` in another process than ``not_pid``."""
    st = {e["id"]: e for e in srv.status()["engines"]}.get(name)
    return st is not None and st["up"] and st["pid"] != not_pid


def test_runs_share_the_engines_and_each_recording_is_the_offline_run(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    srv = on_broker(tmp_path, redis_server).start()
    try:
        with srv.client() as c:
            ids = [c.post("/runs", json={**LONG, "duration": 4.0}).json()["id"] for _ in range(6)]
            # a change, a pause and a resume go to the engine that steps the run
            applied = c.post(
                f"/runs/{ids[0]}/params",
                json={"controller": {"kind": "state_feedback", "K": NEW_K}, "signal": NEW_SQUARE},
            ).json()
            assert c.post(f"/runs/{ids[1]}/pause").json()["status"] == "paused"
            assert c.post(f"/runs/{ids[1]}/resume").json()["status"] == "running"
            for rid in ids:
                until(lambda rid=rid: c.get(f"/runs/{rid}").json()["status"] == "finished")
            by_engine = Counter(engines_of(srv).values())
            assert by_engine == {"sim-0": 3, "sim-1": 3}, by_engine  # the least busy first
            for i, rid in enumerate(ids):
                info = c.get(f"/runs/{rid}").json()
                assert info["n_samples"] == 4000
                want = offline(4.0, change_at=applied["k"] if i == 0 else None)
                got = downloads(c, rid)
                for fmt in ("csv", "json", "mat"):
                    np.testing.assert_array_equal(got[fmt], want, err_msg=f"{rid} {fmt}")
    finally:
        srv.stop()


def test_a_killed_engine_interrupts_only_its_runs_and_is_replaced(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    srv = on_broker(tmp_path, redis_server).start()
    try:
        with srv.client() as c:
            a, b = (c.post("/runs", json=LONG).json()["id"] for _ in range(2))
            until(lambda: c.get(f"/runs/{a}").json()["n_samples"] >= 1000)
            engines = engines_of(srv)
            assert engines[a] != engines[b]
            victim = engine_pid(srv, engines[a])

            async def scenario() -> dict[str, Any]:
                w = await Watcher.open(srv.ws_url, a, "?from_seq=0")
                os.kill(victim, signal.SIGKILL)
                end = await w.until_status({"interrupted"}, timeout=90)
                await w.conn.close()
                return end

            end = asyncio.run(scenario())
            info = c.get(f"/runs/{a}").json()
            assert info["status"] == "interrupted"
            # said by the web process (no heartbeat for 5 s) or by the engine started again
            # in its place, if that came first (it ends its predecessor's runs)
            said = (f"engine {engines[a]} sent nothing for 5 s", "its process ended unexpectedly")
            assert any(s in info["error"] for s in said), info["error"]
            got = downloads(c, a)["csv"]
            assert end["k"] == info["n_samples"] == got.shape[0]
            assert 500 <= got.shape[0] < 60_000
            np.testing.assert_array_equal(got, offline(60.0)[: got.shape[0]])
            # the other engine's run goes on
            assert c.get(f"/runs/{b}").json()["status"] == "running"
            # the killed engine's supervisor (here: the test's) starts it again; it takes runs
            until(lambda: reported(srv, engines[a], not_pid=victim))
            new = [c.post("/runs", json={**LONG, "duration": 0.5}).json()["id"] for _ in range(2)]
            for rid in new:
                until(lambda rid=rid: c.get(f"/runs/{rid}").json()["status"] == "finished")
            assert engines[a] in {engines_of(srv)[rid] for rid in new}
            assert c.post(f"/runs/{b}/stop").json()["status"] == "stopped"
    finally:
        srv.stop()


def test_an_engine_stopped_past_the_stall_loses_its_runs_and_closes_when_it_goes_on(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    srv = on_broker(tmp_path, redis_server).start()
    try:
        with srv.client() as c:
            rid, name, pid = a_second_into_a_long_run(srv, c)
            os.kill(pid, signal.SIGSTOP)
            try:
                info = until(
                    lambda: (i := c.get(f"/runs/{rid}").json())["status"] == "interrupted" and i,
                    timeout=90,
                )
            finally:
                os.kill(pid, signal.SIGCONT)
            assert f"engine {name} sent nothing" in info["error"]
            # going on, it is told to close: it must not step a run the lab has ended
            until(lambda: engine_pid(srv, name) != pid, timeout=90)
            assert "reports again after it was lost" in srv.log
            again = c.get(f"/runs/{rid}").json()
            assert again["status"] == "interrupted" and again["n_samples"] < 60_000
            got = downloads(c, rid)["csv"]
            assert got.shape[0] == again["n_samples"]
            np.testing.assert_array_equal(got, offline(60.0)[: got.shape[0]])
            new = c.post("/runs", json={**LONG, "duration": 0.5}).json()["id"]
            until(lambda: c.get(f"/runs/{new}").json()["status"] == "finished")
    finally:
        srv.stop()


def test_a_broker_killed_and_started_again_empty_loses_no_run(tmp_path: Path) -> None:
    """redis-server killed (everything it held gone: streams, the registry) and started
    again on its port 2 s later, under two live runs: the engines retry their writes and
    announce themselves again, the web process reads on and takes what it missed from the
    store; the runs end whole, equal to the offline simulation, and new runs work."""
    broker = RedisServer()
    broker.start()
    srv = on_broker(tmp_path, broker, ELAB_ENGINE_STALL="30").start()
    try:
        with srv.client() as c:
            ids = [c.post("/runs", json={**LONG, "duration": 8.0}).json()["id"] for _ in range(2)]
            until(lambda: c.get(f"/runs/{ids[0]}").json()["n_samples"] >= 1000)
            broker.kill9()
            time.sleep(2.0)
            broker.start()
            for rid in ids:
                info = until(
                    lambda rid=rid: (
                        (i := c.get(f"/runs/{rid}").json())["status"] == "finished" and i
                    ),
                    timeout=120,
                )
                assert info["n_samples"] == 8000
                np.testing.assert_array_equal(downloads(c, rid)["csv"], offline(8.0))
            until(lambda: sum(e["up"] for e in srv.status()["engines"]) == 2, timeout=60)
            new = c.post("/runs", json={**LONG, "duration": 0.5})
            assert new.status_code == 201, new.text
            rid = new.json()["id"]
            until(lambda: c.get(f"/runs/{rid}").json()["status"] == "finished")
            assert c.get("/health").status_code == 200
    finally:
        srv.stop()
        broker.stop()


def test_a_web_process_started_again_follows_the_runs_its_engines_kept(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    """``kill -9`` of the web process: its engines, processes of their own, step the runs
    on. Started again, it asks them for their live runs: a watcher from sample 0 gets every
    sample (the start from the store, the rest live), a pause and a stop through it work,
    and a run that ends meanwhile is stored whole."""
    srv = on_broker(tmp_path, redis_server).start()
    try:
        with srv.client() as c:
            long = c.post("/runs", json=LONG).json()["id"]
            short = c.post("/runs", json={**LONG, "duration": 8.0}).json()["id"]
            until(lambda: c.get(f"/runs/{long}").json()["n_samples"] >= 1000)
        srv.kill9(engines=False)
        srv.start()
        with srv.client() as c:
            assert c.post(f"/runs/{long}/pause").json()["status"] == "paused"
            assert c.post(f"/runs/{long}/resume").json()["status"] == "running"

            async def scenario() -> Watcher:
                w = await Watcher.open(srv.ws_url, short, "?from_seq=0", as_=c)
                end = await w.until_status({"finished", "interrupted", "stopped"}, timeout=60)
                assert end["state"] == "finished", end
                await w.conn.close()
                return w

            w = asyncio.run(scenario())
            k0, cols = w.samples()
            assert k0 == 0 and len(cols["u"]) == 8000  # every sample, across the restart
            np.testing.assert_array_equal(cols["u"], offline(8.0)[:, 1].astype("<f4"))
            np.testing.assert_array_equal(downloads(c, short)["csv"], offline(8.0))
            stopped = c.post(f"/runs/{long}/stop").json()
            assert stopped["status"] == "stopped", stopped
            got = downloads(c, long)["csv"]
            assert got.shape[0] == stopped["n_samples"]
            np.testing.assert_array_equal(got, offline(60.0)[: got.shape[0]])
    finally:
        srv.stop()


def test_two_web_processes_follow_and_command_the_same_runs(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    """Two ``elab serve`` on one store and broker (as behind a load balancer): a run
    started through one is watched, paused, resumed and changed through the other, every
    sample reaches the watcher, the recording is the offline run with the change, both say
    the same; its owner watching through the second keeps the first from pausing it as
    unwatched (ELAB_OWNER_GRACE 2 s): owners' presence is shared."""
    a = on_broker(tmp_path, redis_server, ELAB_OWNER_GRACE="2").start()
    b = a.another_node().start()
    try:
        with (
            a.client() as ca,
            httpx.Client(
                base_url=b.url + "/api/v1", cookies=a.cookies, timeout=30, verify=TLS
            ) as cb,
        ):
            rid = ca.post("/runs", json={**LONG, "duration": 6.0}).json()["id"]

            async def post(path: str, **kw: Any) -> dict[str, Any]:
                r = await asyncio.to_thread(cb.post, path, **kw)
                assert r.status_code == 200, r.text
                return r.json()  # type: ignore[no-any-return]

            async def scenario() -> tuple[Watcher, dict[str, Any]]:
                w = await Watcher.open(b.ws_url, rid, "?from_seq=0", as_=cb)
                ends = {"finished", "stopped", "interrupted", "failed"}
                reading = asyncio.create_task(w.until_status(ends, timeout=120))
                await until_async(lambda: _received(w) >= 1000)
                assert (await post(f"/runs/{rid}/pause"))["status"] == "paused"
                await asyncio.sleep(0.3)
                assert (await post(f"/runs/{rid}/resume"))["status"] == "running"
                law = {"kind": "state_feedback", "K": NEW_K}
                applied = await post(
                    f"/runs/{rid}/params", json={"controller": law, "signal": NEW_SQUARE}
                )
                end = await reading
                assert end["state"] == "finished", end  # never stopped as unwatched
                await w.conn.close()
                return w, applied

            w, applied = asyncio.run(scenario())
            k = applied["k"]
            want = offline(6.0, change_at=k)
            n, cols = w.samples()
            assert n == 0 and len(cols["u"]) == 6000  # every sample, through the other node
            np.testing.assert_array_equal(cols["u"], want[:, 1].astype("<f4"))
            for c in (ca, cb):
                info = until(
                    lambda c=c: (i := c.get(f"/runs/{rid}").json())["status"] == "finished" and i
                )
                assert [p["k"] for p in info["param_changes"]] == [k]
                np.testing.assert_array_equal(downloads(c, rid)["csv"], want)
            states = [m["state"] for m in w.messages if m["type"] == "status"]
            assert states.count("paused") == 1, states  # the one asked for
    finally:
        b.stop()
        a.stop()


def test_without_an_engine_runs_are_refused_with_503_and_why(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    srv = on_broker(tmp_path, redis_server).start()
    try:
        srv._stop_engines()
        with srv.client() as c:
            health = until(
                lambda: (
                    (r := c.get("/health")).status_code == 503
                    and "no simulation engine has reported" in r.json()["problems"][0]
                    and r.json()
                )
            )
            assert "`elab engine`" in health["problems"][0]
            assert srv.status()["engines"] == []  # each left the broker as it stopped
            r = c.post("/runs", json={**LONG, "duration": 0.5})
            assert r.status_code == 503, r.text
            assert "no simulation engine is running" in r.json()["error"]["message"]
            assert "Retry-After" in r.headers
    finally:
        srv.stop()


def test_an_engine_stops_in_order_its_runs_interrupted_with_their_data(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    srv = on_broker(tmp_path, redis_server).start()
    try:
        with srv.client() as c:
            rid, _, pid = a_second_into_a_long_run(srv, c)
            os.kill(pid, signal.SIGTERM)  # as systemd stops it
            info = until(
                lambda: (i := c.get(f"/runs/{rid}").json())["status"] == "interrupted" and i
            )
            assert "the engine was shut down" in info["error"]
            got = downloads(c, rid)["csv"]
            assert got.shape[0] == info["n_samples"]  # everything it stepped, stored
            np.testing.assert_array_equal(got, offline(60.0)[: got.shape[0]])
    finally:
        srv.stop()
    assert "Traceback" not in srv.log, srv.log[-3000:]


def run_elab(*args: str, **env: str) -> subprocess.CompletedProcess[str]:
    environ = {k: v for k, v in os.environ.items() if not k.startswith("ELAB_")}
    return subprocess.run(
        [ELAB, *args], env={**environ, **env}, capture_output=True, text=True, timeout=120
    )


@pytest.mark.parametrize(
    ("args", "env", "names"),
    [
        ((), {}, "ELAB_REDIS_URL"),
        ((), {"ELAB_REDIS_URL": "http://127.0.0.1:1/0"}, "ELAB_REDIS_URL"),
        (("--name", "a:b"), {"ELAB_REDIS_URL": "redis://127.0.0.1:1/0"}, "--name"),
        (("--name", "web"), {"ELAB_REDIS_URL": "redis://127.0.0.1:1/0"}, "--name"),
    ],
)
def test_elab_engine_refuses_what_it_cannot_use_by_name(
    tmp_path: Path, args: tuple[str, ...], env: dict[str, str], names: str
) -> None:
    done = run_elab("engine", *args, ELAB_DATA=str(tmp_path), **env)
    assert done.returncode == 2, done
    assert done.stderr.startswith("error: ") and names in done.stderr, done.stderr
    assert "Traceback" not in done.stderr


def test_elab_engine_says_when_the_broker_does_not_answer(tmp_path: Path) -> None:
    done = run_elab("engine", ELAB_DATA=str(tmp_path), ELAB_REDIS_URL="redis://127.0.0.1:1/0")
    assert done.returncode == 2, done
    assert "the broker at redis://127.0.0.1:1/0 does not answer" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr


def test_a_second_engine_of_the_same_name_is_refused(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    srv = on_broker(tmp_path, redis_server).start()
    try:
        env = {k: v for k, v in srv.env.items() if k.startswith("ELAB_")}
        done = run_elab("engine", "--name", "sim-0", **env)
        assert done.returncode == 2, done
        assert "'sim-0' is already running on this store" in done.stderr, done.stderr
    finally:
        srv.stop()
