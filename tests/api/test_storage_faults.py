"""Storage faults injected for real under a running server: the database locked by another
process past the busy timeout, a full file system, the file made immutable, a second server
started on the same store. In each no run stays live, nothing committed is lost, /server and
/health say what happened, and once the fault clears new runs work."""

from __future__ import annotations

import math
import subprocess
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from elab.plants import get_plant
from elab.sim import RunSpec, Square, simulate
from tests.api.server import ELAB, START_CAP, Server, until
from tests.api.test_live_runs import downloads
from tests.postgres import PostgresServer
from tests.unit.store.test_versions_and_faults import _chattr

FLEX = get_plant("flexible_link")
SQUARE = {"kind": "square", "amplitude": math.radians(30), "period": 2.0}


def offline(duration: float) -> np.ndarray:
    res = simulate(RunSpec(FLEX, FLEX.predefined, Square(math.radians(30), 2.0), duration=duration))
    return np.column_stack([res.r, res.u, res.y, res.x])


def start_run(srv: Server, duration: float) -> str:
    with srv.client() as c:
        r = c.post("/runs", json={"plant": "flexible_link", "signal": SQUARE, "duration": duration})
        assert r.status_code == 201, r.text
        rid = str(r.json()["id"])
        until(lambda: c.get(f"/runs/{rid}").json()["n_samples"] > 600)
        return rid


def assert_failed_with_its_data_and_refusing(srv: Server, rid: str, reason: str) -> None:
    """The run failed naming the fault, kept what was committed, and new runs get 503."""
    with srv.client() as c:
        info = until(lambda: (i := c.get(f"/runs/{rid}").json())["status"] == "failed" and i)
        assert "storage failed" in info["error"] and reason in info["error"], info["error"]
        got = downloads(c, rid)["csv"]
        assert got.shape[0] == info["n_samples"] > 0
        np.testing.assert_array_equal(got, offline(60.0)[: got.shape[0]])
        st = srv.status()
        assert st["live_runs"] == 0 and not st["store"]["ok"] and not st["store"]["transient"]
        health = c.get("/health")
        assert health.status_code == 503 and reason in health.json()["problems"][0]
        r = c.post("/runs", json={"plant": "belt_conveyor"})
        assert r.status_code == 503 and "store" in r.json()["error"]["message"], r.text


def assert_recovered(srv: Server) -> None:
    with srv.client() as c:
        until(lambda: c.get("/health").json()["status"] == "ok")
        r = c.post("/runs", json={"plant": "flexible_link", "duration": 1, "pace": "fast"})
        assert r.status_code == 201, r.text
        rid = r.json()["id"]
        info = until(lambda: (i := c.get(f"/runs/{rid}").json())["status"] == "finished" and i)
        assert info["n_samples"] == 1000 and downloads(c, rid)["csv"].shape[0] == 1000


def test_a_store_locked_by_another_process_is_retried_and_loses_nothing(tmp_path: Path) -> None:
    srv = Server(tmp_path / "data").start()
    try:
        rid = start_run(srv, 12.0)
        with srv.store_locked() as release:
            # past the 5 s busy (lock) timeout: the engine retries and says so
            store = until(lambda: (s := srv.status()["store"])["transient"] and s, 30)
            assert "locked" in store["error"] and store["pending_bytes"] > 0
            with srv.client() as c:
                health = c.get("/health")
                assert health.status_code == 200 and health.json()["status"] == "degraded"
                assert c.get(f"/runs/{rid}").json()["status"] == "running"  # going on
            release()  # the other process lets go
        with srv.client() as c:
            until(lambda: c.get(f"/runs/{rid}").json()["status"] == "finished")
            np.testing.assert_array_equal(downloads(c, rid)["csv"], offline(12.0))  # complete
            assert srv.status()["store"]["ok"]
        assert_recovered(srv)
    finally:
        srv.stop()


@pytest.mark.local_engine_only(
    "on a broker web servers share a store (test_engines_on_broker: two web processes)"
)
def test_a_second_server_on_the_same_store_stops_and_the_first_goes_on(tmp_path: Path) -> None:
    """Its engine would have marked the first one's live runs interrupted (both call theirs
    sim-0); it says why it stops, and the first one's run ends whole."""
    srv = Server(tmp_path / "data").start()
    try:
        rid = start_run(srv, 8.0)
        second = Server(srv.data, **{k: srv.env[k] for k in ("ELAB_DATABASE_URL",) if k in srv.env})
        ended = subprocess.run(
            [ELAB, "serve", "--port", str(second.port)],
            env=second.env,
            capture_output=True,
            text=True,
            timeout=START_CAP,
            check=False,
        )
        assert ended.returncode != 0
        assert "'web' is already running on this store" in ended.stdout + ended.stderr
        with srv.client() as c:  # not interrupted: it ran on and ended whole
            until(lambda: c.get(f"/runs/{rid}").json()["status"] == "finished")
            info = c.get(f"/runs/{rid}").json()
            assert (info["n_samples"], info["error"]) == (8_000, None), info
            np.testing.assert_array_equal(downloads(c, rid)["csv"], offline(8.0))
    finally:
        srv.stop()


def test_postgres_restarting_under_a_run_loses_nothing(tmp_path: Path) -> None:
    """The database restarts (every session ended) while a run records: the engine's
    writes fail transiently and are retried on new connections, the run ends whole,
    requests meanwhile get at most a 503 that says to retry, and the service returns."""
    pg = PostgresServer()
    pg.start()
    srv = Server(tmp_path / "data", ELAB_DATABASE_URL=pg.schema()).start()
    try:
        rid = start_run(srv, 10.0)
        pg.restart()
        with srv.client() as c:
            seen: set[int] = set()

            def finished() -> bool:
                r = c.get(f"/runs/{rid}")
                seen.add(r.status_code)
                return r.status_code == 200 and r.json()["status"] == "finished"

            until(finished, 120)
            assert seen <= {200, 503}, seen
            info = c.get(f"/runs/{rid}").json()
            assert (info["n_samples"], info["error"]) == (10_000, None)
            np.testing.assert_array_equal(downloads(c, rid)["csv"], offline(10.0))
            until(lambda: c.get("/health").json()["status"] == "ok", 60)
            r = c.post("/runs", json={"plant": "belt_conveyor", "duration": 1.0, "pace": "fast"})
            assert r.status_code == 201, r.text
    finally:
        srv.stop()
        pg.stop()


@pytest.fixture
def small_fs(tmp_path: Path) -> Iterator[Path]:
    """A 24 MiB tmpfs (a file system that can fill up), unmounted afterwards."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    r = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=24m", "tmpfs", str(mnt)],
        capture_output=True,
        text=True,
        check=False,
    )
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here (needs CAP_SYS_ADMIN): {r.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


@pytest.mark.sqlite_only("the data directory's file system filling up")
def test_a_full_file_system_fails_the_runs_keeps_their_data_and_recovers(small_fs: Path) -> None:
    srv = Server(small_fs / "data").start()
    try:
        rid = start_run(srv, 60.0)
        filler = small_fs / "filler"
        with filler.open("wb") as f:  # take every free byte
            try:
                while True:
                    f.write(bytes(1 << 16))
                    f.flush()
            except OSError:
                pass
        assert_failed_with_its_data_and_refusing(srv, rid, "full")
        filler.unlink()
        assert_recovered(srv)
    finally:
        srv.stop()


@pytest.mark.sqlite_only("the database file made immutable")
def test_a_store_made_immutable_fails_the_runs_keeps_their_data_and_recovers(
    tmp_path: Path,
) -> None:
    srv = Server(tmp_path / "data").start()
    files = [srv.data / "elab.sqlite3", srv.data / "elab.sqlite3-wal"]
    try:
        rid = start_run(srv, 60.0)
        if not _chattr("+i", *files):
            pytest.skip("chattr +i is not possible here (needs CAP_LINUX_IMMUTABLE, ext4/xfs)")
        try:
            assert_failed_with_its_data_and_refusing(srv, rid, "I/O error")
        finally:
            _chattr("-i", *files)
        assert_recovered(srv)
    finally:
        _chattr("-i", *files)
        srv.stop()
