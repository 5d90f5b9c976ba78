"""The rig queue in the SQLite store: it survives a restart, a file of schema version 7
upgrades to take it, the tables themselves refuse a second driver, and two users asking
for the seat at once (threads, processes) never both get it."""

from __future__ import annotations

import multiprocessing
import queue
import sqlite3
import threading
from pathlib import Path

import pytest

from elab.errors import Conflict
from elab.rig_queue import Arm, Join, Phase, QueuePolicy, RigQueue, SetService, Start, Tick
from elab.store import SQLiteStore, open_store
from elab.store._db import SCHEMA_VERSION
from tests.unit.store import rig_race
from tests.unit.store.test_versions_and_faults import restored

V7 = Path(__file__).resolve().parents[2] / "reference" / "store" / "v7.sql"
P = QueuePolicy(slot=300.0, grace=60.0)


def test_a_version_7_file_opens_upgraded_and_takes_a_rig_queue(tmp_path: Path) -> None:
    """Migration 8: the rig queue."""
    path = restored(V7, tmp_path / "v7.sqlite3")
    with SQLiteStore(path) as store:
        assert store.get_run("r-0000000000b7").owner == "a-00b7"
        assert store.read("r-0000000000b7").tolist() == [
            [0.0, 1.0, 2.0, 3.0, 4.0],
            [5.0, 6.0, 7.0, 8.0, 9.0],
        ]
        assert store.rig_queue("flexible_link-1", P, 0.0) == RigQueue()
        store.apply_rig("flexible_link-1", Join("a-1"), P, 0.0)
        assert store.rig_queue("flexible_link-1", P, 1.0).driver == "a-1"
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    conn.close()


def test_the_queue_survives_a_restart_and_time_applies_on_reading(tmp_path: Path) -> None:
    path = tmp_path / "s.sqlite3"
    with SQLiteStore(path) as store:
        for now, op in ((0.0, Join("a")), (1.0, Join("b")), (2.0, Arm("a"))):
            store.apply_rig("rig-1", op, P, now)
        store.apply_rig("rig-1", Start("a", "r-1"), P, 3.0)
        store.apply_rig("rig-2", Join("c"), P, 3.0)
        before = store.rig_queue("rig-1", P, 4.0)
    with SQLiteStore(path) as store:
        assert store.rig_queue("rig-1", P, 4.0) == before
        assert before.seat is not None and before.seat.phase is Phase.RUNNING
        assert before.seat.run_id == "r-1" and before.users == ("a", "b")
        assert store.rig_queue("rig-2", P, 4.0).driver == "c"  # rigs are apart
        later = store.rig_queue("rig-1", P, 300.0)  # a's slot ended
        assert later.driver == "b" and later.settling
    with SQLiteStore(path) as store:
        assert store.rig_queue("rig-1", P, 300.0) == later


def test_a_refused_operation_writes_nothing(tmp_path: Path) -> None:
    with SQLiteStore(tmp_path / "s.sqlite3") as store:
        store.apply_rig("rig", Join("a"), P, 0.0)
        store.apply_rig("rig", SetService("encoder fault"), P, 1.0)
        with pytest.raises(Conflict, match=r"out of service \(encoder fault\)"):
            store.apply_rig("rig", Arm("a"), P, 2.0)
        q = store.rig_queue("rig", P, 2.0)
        assert (q.users, q.seat, q.out_of_service) == (("a",), None, "encoder fault")


def test_the_tables_refuse_a_second_driver_and_a_driver_not_at_the_head(tmp_path: Path) -> None:
    path = tmp_path / "s.sqlite3"
    with SQLiteStore(path) as store:
        store.apply_rig("rig", Join("a"), P, 0.0)
        store.apply_rig("rig", Join("b"), P, 0.0)
    conn = sqlite3.connect(path, isolation_level=None)
    conn.execute("PRAGMA foreign_keys = ON")
    second = (
        "INSERT INTO rig_seat (rig, user_id, phase, since, until, took_over) "
        "VALUES ('rig', 'b', 'seated', 0, 300, 0)"
    )
    with pytest.raises(sqlite3.IntegrityError, match=r"UNIQUE constraint failed: rig_seat\.rig"):
        conn.execute(second)
    conn.execute("BEGIN")
    conn.execute("DELETE FROM rig_seat")
    conn.execute(second)  # b is at place 2: the deferred foreign key fails the commit
    with pytest.raises(sqlite3.IntegrityError, match="FOREIGN KEY constraint failed"):
        conn.execute("COMMIT")
    conn.execute("ROLLBACK")
    with pytest.raises(sqlite3.IntegrityError, match="CHECK constraint failed"):
        conn.execute("UPDATE rig_seat SET phase = 'running'")  # running without a run
    conn.close()


ROUNDS = 100


def check_race(results: list[tuple[int, str, str | None, int | None]], target: str) -> None:
    """Per round: both joins answered, one driver, whom both saw; the loser at place 2."""
    assert len(results) == 2 * ROUNDS
    with open_store(target) as store:
        for k in range(ROUNDS):
            seen = sorted(r for r in results if r[0] == k)
            assert len(seen) == 2
            q = store.rig_queue(f"race-{k}", P, float(k))
            assert q.driver in ("x", "y") and len(q.users) == 2
            for _, user, driver, place in seen:
                assert place == q.place(user)
                assert driver == q.driver  # the first to commit is seated, the second sees it
            assert sorted(place for *_, place in seen) == [1, 2]


def test_two_users_asking_at_once_from_threads_never_both_drive(target: str) -> None:
    barrier = threading.Barrier(2)
    out: queue.Queue[tuple[int, str, str | None, int | None]] = queue.Queue()
    threads = [
        threading.Thread(target=rig_race.contend, args=(target, u, ROUNDS, barrier, out))
        for u in ("x", "y")
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    check_race([out.get() for _ in range(2 * ROUNDS)], target)


def test_two_users_asking_at_once_from_processes_never_both_drive(target: str) -> None:
    ctx = multiprocessing.get_context("spawn")
    barrier, out = ctx.Barrier(2), ctx.Queue()
    procs = [
        ctx.Process(target=rig_race.contend, args=(target, u, ROUNDS, barrier, out))
        for u in ("x", "y")
    ]
    for p in procs:
        p.start()
    results = [out.get(timeout=60) for _ in range(2 * ROUNDS)]
    for p in procs:
        p.join(timeout=30)
        assert p.exitcode == 0
    check_race(results, target)
    # and a join after the rounds still sees the store as every process left it
    with open_store(target) as store:
        assert store.apply_rig("race-0", Tick(), P, 0.0).queue.users in (("x", "y"), ("y", "x"))
