"""An embedded lab's records copied into another store (``elab migrate --from FILE``): into
PostgreSQL and into another file (the ``store`` fixture), everything reads back the same
through every method of the protocols, lists in the same newest-first order; a
destination with records and a file a server is using are refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from elab.errors import Conflict, ElabError
from elab.rig_queue import Arm, Join, QueuePolicy
from elab.store import ParamChange, Pin, SQLiteStore, Store, StoredController, StoredModel, Token
from elab.store.copy import copy_records
from elab.store.sql.tables import Tables
from tests.unit.store.test_sqlite import NCH, chunks, fill, record

P = QueuePolicy()


def filled_file(path: Path) -> tuple[SQLiteStore, dict[str, np.ndarray]]:
    """A file with some of everything: runs (finished, failed, private) with samples in
    many chunks, parameter changes, a pin, tokens, controllers, models, an ended session
    and a rig queue with a seated driver."""
    src = SQLiteStore(path)
    data = {}
    gen = chunks(7)
    for i in range(5):
        rid = f"r-{i}"
        src.create_run(
            record(rid, created_at=1.7e9 + (i % 3), owner=f"u{i % 2}", private=i == 3)
        )  # equal times: the copy keeps their arrival order
        data[rid] = fill(src, rid, [next(gen) for _ in range(3 + i)])
        src.add_param_change(rid, ParamChange(5, {"K": [1.0, i]}, 1.7e9 + 1))
        src.set_status(rid, "failed" if i == 4 else "finished", finished_at=1.7e9 + 9)
    src.set_pin(Pin("demo", "r-2", "teacher", 1.7e9 + 5))
    src.add_token(Token("t-1", "u0", "laptop", 1.7e9, 1.7e9 + 3), "d" * 64)
    src.add_token(Token("t-2", "u1", "grader", 1.7e9 + 1), "e" * 64)
    for j in range(3):
        src.add_controller(
            StoredController(
                f"c-{j}", "u0", "flexible_link", f"ctl {j}", "toml", {"K": [j]}, {"ok": True},
                1.7e9, source=bytes(range(j, 200)),
            )
        )  # fmt: skip
        src.add_model(StoredModel(f"m-{j}", "u1", "belt_conveyor", f"arx {j}", {"A": [j]}, 1.7e9))
    src.end_session("s-1", 4e9)
    src.apply_rig("flexible_link", Join("u0"), P, 1.7e9)
    src.apply_rig("flexible_link", Join("u1"), P, 1.7e9 + 1)
    src.apply_rig("flexible_link", Arm("u0"), P, 1.7e9 + 2)
    return src, data


def test_everything_reads_back_the_same_from_the_copy(store: Store, tmp_path: Path) -> None:
    src, data = filled_file(tmp_path / "old.sqlite3")
    assert isinstance(store, Tables)
    with src:
        copied = copy_records(src, store)
    assert copied["runs"] == 5 and copied["chunks"] == sum(3 + i for i in range(5))
    with SQLiteStore(tmp_path / "old.sqlite3") as src:  # read again, the copy's claim gone
        for viewer in (None, "u0", "u1"):
            assert store.list_runs(viewer=viewer) == src.list_runs(viewer=viewer)
        for rid, rows in data.items():
            assert store.get_run(rid) == src.get_run(rid)
            assert np.array_equal(store.read(rid), rows) and store.read(rid).shape[1] == NCH
            assert np.array_equal(store.read(rid, 17, 90), rows[17:90])
            assert store.param_changes(rid) == src.param_changes(rid)
        assert store.pin("demo") == src.pin("demo")
        for owner in ("u0", "u1"):
            assert store.tokens(owner) == src.tokens(owner)
            assert store.usage(owner) == src.usage(owner)
        assert store.token_by_digest("d" * 64) == src.token_by_digest("d" * 64)
        assert store.list_controllers("u0") == src.list_controllers("u0")
        assert store.get_controller("c-2").source == bytes(range(2, 200))
        assert store.list_models(None) == src.list_models(None)
        assert store.ended_sessions(1.8e9) == {"s-1"}
        q = store.rig_queue("flexible_link", P, 1.7e9 + 3)
        assert q == src.rig_queue("flexible_link", P, 1.7e9 + 3) and q.driver == "u0"
        assert store.ended_before(2e9) == src.ended_before(2e9)
    # and the copy is a store like any other: it takes new runs after the old ones
    store.create_run(record("r-new", created_at=1.7e9 + 2))
    assert store.list_runs(limit=1)[0][0].id == "r-new"


def test_a_destination_holding_records_is_refused_and_left_alone(
    store: Store, tmp_path: Path
) -> None:
    src, _ = filled_file(tmp_path / "old.sqlite3")
    store.create_run(record("mine"))
    assert isinstance(store, Tables)
    with src, pytest.raises(Conflict, match=r"already holds records \(1 runs\)"):
        copy_records(src, store)
    assert [r.id for r in store.list_runs()[0]] == ["mine"]


def test_a_file_a_server_is_using_is_refused(store: Store, tmp_path: Path) -> None:
    src, _ = filled_file(tmp_path / "old.sqlite3")
    with SQLiteStore(tmp_path / "old.sqlite3") as server:
        server.claim("web")
        assert isinstance(store, Tables)
        with src, pytest.raises(ElabError, match=r"'web' is already running on this store"):
            copy_records(src, store)
    assert store.list_runs()[1] == 0
