"""Identified models kept for design in the SQLite store (real files): add, get, list by
owner and plant, count, delete; and a file of schema version 5 upgraded with its runs and
controllers intact, taking models."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from elab.errors import Conflict, InvalidInput, NotFound
from elab.store import SQLiteStore, Store, StoredModel
from elab.store._db import SCHEMA_VERSION
from tests.unit.store.test_versions_and_faults import restored

V5 = Path(__file__).resolve().parents[2] / "reference" / "store" / "v5.sql"
DOC = {
    "Ts": 0.001,
    "A": [[0.9, 0.1], [0.0, 0.8]],
    "B": [[0.0], [1.0]],
    "C": [[1.0, 0.0]],
    "D": [[0.0]],
    "input": {"name": "u", "unit": "V"},
    "outputs": [{"name": "theta", "unit": "rad"}],
    "source": "run r-1",
    "fit": [89.7],
}


def model(
    id_: str, owner: str = "a-1", plant: str = "flexible_link", at: float = 1.0
) -> StoredModel:
    return StoredModel(id_, owner, plant, f"arx {id_}", DOC, at)


def test_a_model_is_kept_listed_by_owner_and_plant_and_deleted(store: Store) -> None:
    store.add_model(model("m-1", at=1.0))
    store.add_model(model("m-2", at=2.0, plant="belt_conveyor"))
    store.add_model(model("m-3", owner="a-2", at=3.0))
    assert store.get_model("m-1") == model("m-1", at=1.0)
    assert store.get_model("m-1").model == DOC  # the document as given, numbers exact
    assert [m.id for m in store.list_models("a-1")] == ["m-2", "m-1"]  # newest first
    assert [m.id for m in store.list_models("a-1", "flexible_link")] == ["m-1"]
    assert [m.id for m in store.list_models(None)] == ["m-3", "m-2", "m-1"]
    assert (store.count_models("a-1"), store.count_models("a-2"), store.count_models("x")) == (
        2,
        1,
        0,
    )
    store.delete_model("m-1")
    with pytest.raises(NotFound, match="unknown model 'm-1'"):
        store.get_model("m-1")
    with pytest.raises(NotFound):
        store.delete_model("m-1")
    assert store.count_models("a-1") == 1


def test_a_model_id_is_unique_and_its_document_json(store: Store) -> None:
    store.add_model(model("m-1"))
    with pytest.raises(Conflict):
        store.add_model(model("m-1"))
    with pytest.raises(InvalidInput, match="model"):
        store.add_model(StoredModel("m-2", "a-1", "flexible_link", "x", {"A": float("nan")}, 1))
    assert store.count_models("a-1") == 1


def test_a_version_5_file_keeps_runs_and_controllers_and_takes_models(tmp_path: Path) -> None:
    path = restored(V5, tmp_path / "v5.sqlite3")
    with SQLiteStore(path) as store:
        run = store.get_run("r-0000000000c5")
        assert (run.owner, run.n_stored, run.compute) == (
            "a-00c5",
            2,
            {"steps": 2, "median_us": 11.0, "p99_us": 20.0, "max_us": 21.0, "misses": 0},
        )
        assert store.read(run.id).tolist() == [[0.0, 1.0], [2.0, 3.0]]
        c = store.get_controller("c-0000000000c5")
        assert (c.format, c.law, c.source) == (
            "py",
            {"kind": "python", "file": "mine.py"},
            b"class",
        )
        assert store.list_models(None) == []
        store.add_model(model("m-1", owner="a-00c5"))
        assert store.list_models("a-00c5") == [model("m-1", owner="a-00c5")]
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    conn.close()
