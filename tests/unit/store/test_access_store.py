"""Owners, private runs, deletion, usage and retention, API tokens and pins in the SQLite
store (real files), and a file of schema version 2 upgraded with its runs intact."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

import numpy as np
import pytest

from elab.errors import Conflict, NotFound
from elab.store import ParamChange, Pin, SQLiteStore, Store, Token
from elab.store._db import SCHEMA_VERSION
from tests.unit.store.test_sqlite import NCH, record
from tests.unit.store.test_versions_and_faults import restored

V2 = Path(__file__).resolve().parents[2] / "reference" / "store" / "v2.sql"


def test_a_version_2_file_opens_upgraded_and_its_runs_have_no_owner(tmp_path: Path) -> None:
    path = restored(V2, tmp_path / "v2.sqlite3")
    with SQLiteStore(path) as store:
        run = store.get_run("r-0000000000b2")
        assert (run.status, run.n_stored, run.engine) == ("stopped", 25, "sim-0")
        assert (run.owner, run.private) == (None, False)
        np.testing.assert_array_equal(
            store.read("r-0000000000b2"), np.random.default_rng(2).standard_normal((25, 3))
        )
        assert store.param_changes("r-0000000000b2") == [
            ParamChange(10, {"signal": {"kind": "step", "amplitude": 0.5}}, 1.75e9 + 0.02)
        ]
        store.create_run(record("r-new", owner="a-1234"))
        assert store.get_run("r-new").owner == "a-1234"
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    conn.close()


def test_lists_by_owner_hide_private_runs_from_others(store: Store) -> None:
    store.create_run(record("r-a", owner="a-1", created_at=1))
    store.create_run(record("r-b", owner="a-2", private=True, created_at=2))
    store.create_run(record("r-c", owner="a-2", created_at=3))

    def ids(**kw: str) -> list[str]:
        runs, total = store.list_runs(**kw)  # type: ignore[arg-type]
        assert total == len(runs)
        return [r.id for r in runs]

    assert ids() == ["r-c", "r-b", "r-a"]  # everything (an instructor)
    assert ids(viewer="a-1") == ["r-c", "r-a"]  # a-2's private run hidden from a-1
    assert ids(viewer="a-2") == ["r-c", "r-b", "r-a"]
    assert ids(owner="a-2", viewer="a-1") == ["r-c"]
    assert store.get_run("r-b").private is True


def test_a_deleted_run_is_gone_with_its_samples_and_a_live_one_cannot_be(
    store: Store,
) -> None:
    store.create_run(record("r-1", owner="a-1"))
    store.append("r-1", 0, np.ones((10, NCH)))
    store.add_param_change("r-1", ParamChange(3, {"x": 1}, 1.0))
    with pytest.raises(Conflict, match="stop it before deleting"):
        store.delete_run("r-1")
    store.set_status("r-1", "finished", finished_at=5.0)
    store.set_pin(Pin("demo", "r-1", "i-prof", 6.0))
    assert store.usage("a-1").runs == 1 and store.usage("a-1").bytes == 10 * NCH * 8
    store.delete_run("r-1")
    with pytest.raises(NotFound):
        store.get_run("r-1")
    with pytest.raises(NotFound):
        store.read("r-1")
    assert store.pin("demo") is None
    assert store.usage("a-1").runs == 0 and store.usage("a-1").bytes == 0
    with pytest.raises(NotFound):
        store.delete_run("r-1")


def test_retention_picks_ended_runs_finished_before_a_time_and_spares_pinned_ones(
    store: Store,
) -> None:
    for i, status in enumerate(["finished", "stopped", "running", "failed"]):
        store.create_run(record(f"r-{i}", owner="a-1", created_at=i))
        if status != "running":
            store.set_status(f"r-{i}", status, finished_at=100.0 + i)
    store.set_pin(Pin("demo", "r-1", "i-prof", 0.0))
    assert store.ended_before(103.0) == ["r-0"]  # r-1 pinned, r-2 live, r-3 too recent
    assert store.ended_before(104.0) == ["r-0", "r-3"]


def test_tokens_are_kept_by_digest_per_owner(store: Store) -> None:
    t = Token("t-1", "a-1", "grader", 10.0)
    store.add_token(t, "d" * 64)
    assert store.token_by_digest("d" * 64) == t
    assert store.token_by_digest("e" * 64) is None
    store.touch_token("t-1", 20.0)
    assert store.tokens("a-1") == [Token("t-1", "a-1", "grader", 10.0, 20.0)]
    assert store.tokens("a-2") == []
    with pytest.raises(NotFound):
        store.revoke_token("a-2", "t-1")  # not theirs
    store.revoke_token("a-1", "t-1")
    assert store.token_by_digest("d" * 64) is None


def test_a_pin_names_an_existing_run(store: Store) -> None:
    with pytest.raises(NotFound):
        store.set_pin(Pin("demo", "r-none", "i-prof", 1.0))
    store.create_run(record("r-1"))
    store.set_pin(Pin("demo", "r-1", "i-prof", 1.0))
    assert store.pin("demo") == Pin("demo", "r-1", "i-prof", 1.0)
    store.clear_pin("demo")
    assert store.pin("demo") is None


V3 = V2.with_name("v3.sql")


def test_a_version_3_file_keeps_owners_tokens_and_pins_and_takes_controllers(
    tmp_path: Path,
) -> None:
    from elab.store import StoredController

    with SQLiteStore(restored(V3, tmp_path / "v3.sqlite3")) as store:
        run = store.get_run("r-0000000000c3")
        assert (run.owner, run.private, run.n_stored) == ("a-00c3", True, 12)
        assert store.token_by_digest("e" * 64) == Token("t-0000c3", "a-00c3", "grader", 1.76e9)
        assert store.pin("demo") == Pin("demo", "r-0000000000c3", "i-prof", 1.76e9 + 1)
        c = StoredController(
            "c-1", "a-00c3", "belt_conveyor", "mine", "toml", {"kind": "pid"}, {}, 1.0, b"x"
        )
        store.add_controller(c)
        assert store.get_controller("c-1") == c
        assert store.list_controllers("a-00c3") == [
            StoredController(**{**c.__dict__, "source": b""})
        ]
        assert store.count_controllers("a-00c3") == 1
        store.delete_controller("c-1")
        with pytest.raises(NotFound):
            store.get_controller("c-1")


V4 = V2.with_name("v4.sql")


def test_a_version_4_file_keeps_runs_and_controllers_and_takes_compute_times(
    tmp_path: Path,
) -> None:
    with SQLiteStore(restored(V4, tmp_path / "v4.sqlite3")) as store:
        run = store.get_run("r-0000000000c4")
        assert (run.owner, run.n_stored, run.compute) == ("a-00c4", 3, None)
        assert store.read(run.id).tolist() == [[0.0, 1.0], [2.0, 3.0], [4.0, 5.0]]
        assert store.get_controller("c-0000000000c4").law["K"] == [20, -93.5614, 3.3621, 0.9623]
        times = {"steps": 3, "median_us": 12.5, "p99_us": 30.0, "max_us": 31.0, "misses": 0}
        store.set_status(run.id, "finished", compute=times)
        assert store.get_run(run.id).compute == times


V6 = Path(__file__).resolve().parents[2] / "reference" / "store" / "v6.sql"


def test_a_version_6_file_opens_upgraded_and_sessions_can_end(tmp_path: Path) -> None:
    """Migration 7: the sessions ended by signing out, kept until they would expire."""
    path = restored(V6, tmp_path / "v6.sqlite3")
    with SQLiteStore(path) as store:
        assert store.get_run("r-0000000000b6").status == "finished"
        assert [t.id for t in store.tokens("instructor:prof")] == ["t-0000000000b6"]
        now = time.time()
        assert store.ended_sessions(now) == set()
        store.end_session("s-old", until=now - 10)  # already expired: no record needed
        store.end_session("s-gone", until=now + 3600)
        assert store.ended_sessions(now) == {"s-gone"}
        assert store.ended_sessions(now + 7200) == set()
