"""Schema versions (a file of every earlier version opens and upgrades) and storage faults
caused for real: another process holding the lock, a full database, a file made
immutable. Each fault leaves as a StoreError that says whether retrying makes sense, and
nothing committed is lost."""

from __future__ import annotations

import sqlite3
import subprocess
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from elab.errors import ElabError
from elab.store import ParamChange, SQLiteStore, StoreError
from elab.store._db import SCHEMA_VERSION
from tests.unit.store.test_sqlite import NCH, record

V1 = Path(__file__).resolve().parents[2] / "reference" / "store" / "v1.sql"


def restored(dump: Path, path: Path) -> Path:
    """A store file made from a dump an earlier E-Lab wrote (committed beside the tests)."""
    conn = sqlite3.connect(path)
    conn.executescript(dump.read_text())
    conn.close()
    return path


def v1_file(tmp_path: Path) -> Path:
    """A store as E-Lab's schema version 1 wrote it."""
    return restored(V1, tmp_path / "v1.sqlite3")


def test_a_version_1_file_opens_upgraded_with_everything_in_it(tmp_path: Path) -> None:
    path = v1_file(tmp_path)
    with SQLiteStore(path) as store:
        run = store.get_run("r-0000000000a1")
        assert (run.status, run.n_stored, run.n_planned, run.engine) == ("finished", 50, 50, None)
        data = store.read("r-0000000000a1")
        assert data.shape == (50, 4)
        # the rows as version 1 wrote them: chunks of 30 and 20 from one generator
        rng = np.random.default_rng(1)
        np.testing.assert_array_equal(
            data, np.concatenate([rng.standard_normal((30, 4)), rng.standard_normal((20, 4))])
        )
        assert store.param_changes("r-0000000000a1") == [
            ParamChange(
                30, {"controller": {"kind": "state_feedback", "K": [1, 2, 3, 4]}}, 1.7e9 + 0.03
            )
        ]
        # a run version 1 left live belongs to no engine: no engine's restart touches it
        assert store.mark_interrupted("sim-0", "restart") == []
        store.create_run(record("r-new"))  # and the upgraded file takes new runs
        store.probe()
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    conn.close()


def test_an_engine_refuses_a_file_not_yet_upgraded(tmp_path: Path) -> None:
    with pytest.raises(ElabError, match="schema version 1; this process expects"):
        SQLiteStore(v1_file(tmp_path), migrate=False)


def test_a_list_of_runs_leaves_the_requests_out(tmp_path: Path) -> None:
    with SQLiteStore(tmp_path / "s.sqlite3") as store:
        store.create_run(record("r-1"))
        (summary,), total = store.list_runs()
        assert total == 1 and not hasattr(summary, "spec")
        assert store.get_run("r-1").spec["K"] == [1.5, -2.0, 0.25, 1e-3]


# -- faults ------------------------------------------------------------------------
LOCKER = """
import sqlite3, sys, time
conn = sqlite3.connect(sys.argv[1], isolation_level=None)
conn.execute("BEGIN EXCLUSIVE")
print("locked", flush=True)
sys.stdin.readline()
conn.execute("COMMIT")
"""


@contextmanager
def locked(path: Path) -> Iterator[Callable[[], None]]:
    """Another process holding an exclusive lock on the SQLite file ``path`` until the
    function this yields is called, or the block ends."""
    with subprocess.Popen(
        [sys.executable, "-c", LOCKER, str(path)],
        text=True,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
    ) as locker:
        assert locker.stdout is not None and locker.stdin is not None
        assert locker.stdout.readline().strip() == "locked"
        stdin = locker.stdin

        def release() -> None:
            if not stdin.closed:
                stdin.write("\n")
                stdin.close()

        try:
            yield release
        finally:
            release()


@pytest.fixture
def store(tmp_path: Path) -> Iterator[SQLiteStore]:
    with SQLiteStore(tmp_path / "s.sqlite3", busy_timeout=0.2) as s:
        s.create_run(record("r-1"))
        s.append("r-1", 0, np.ones((10, NCH)))
        yield s


def test_a_lock_held_by_another_process_is_a_transient_fault(store: SQLiteStore) -> None:
    with locked(store.path):
        with pytest.raises(StoreError, match="locked") as err:
            store.append("r-1", 10, np.ones((5, NCH)))
        assert err.value.transient and err.value.retry_after is not None
    store.append("r-1", 10, np.ones((5, NCH)))  # the same write, once the lock is gone
    assert store.get_run("r-1").n_stored == 15


def test_a_full_database_is_a_persistent_fault_and_keeps_what_was_committed(
    store: SQLiteStore,
) -> None:
    pages = store._writer.execute("PRAGMA page_count").fetchone()[0]
    store._writer.execute(f"PRAGMA max_page_count = {pages}")  # no page to grow by
    with pytest.raises(StoreError, match="full") as err:
        store.append("r-1", 10, np.ones((20_000, NCH)))
    assert not err.value.transient
    np.testing.assert_array_equal(store.read("r-1"), np.ones((10, NCH)))
    store._writer.execute("PRAGMA max_page_count = 1073741823")  # space again
    store.append("r-1", 10, np.ones((20_000, NCH)))
    store.probe()


def _chattr(flag: str, *paths: Path) -> bool:
    try:
        return (
            subprocess.run(
                ["chattr", flag, *map(str, paths)], capture_output=True, check=False
            ).returncode
            == 0
        )
    except FileNotFoundError:
        return False


def test_a_file_made_immutable_is_a_persistent_fault(store: SQLiteStore) -> None:
    files = [p for p in (store.path, store.path.with_name(store.path.name + "-wal")) if p.exists()]
    if not _chattr("+i", *files):
        pytest.skip("chattr +i is not possible here (needs CAP_LINUX_IMMUTABLE on ext4/xfs)")
    try:
        with pytest.raises(StoreError) as err:
            store.append("r-1", 10, np.ones((100, NCH)))
        assert not err.value.transient
        with pytest.raises(StoreError):
            store.probe()
        np.testing.assert_array_equal(store.read("r-1"), np.ones((10, NCH)))  # reads work
    finally:
        _chattr("-i", *files)
    store.append("r-1", 10, np.ones((100, NCH)))
    assert store.get_run("r-1").n_stored == 110


def test_a_version_8_file_opens_upgraded_its_runs_outcome_unknown(tmp_path: Path) -> None:
    """Migration 9: a run's outcome (elab.engines.outcome). A run recorded before has
    none (``None``: not known, not "nothing to say"); a run ending now keeps its marks."""
    path = restored(Path(__file__).parents[2] / "reference" / "store" / "v8.sql", tmp_path / "v8")
    with SQLiteStore(path) as store:
        old = store.get_run("r-0000000000c8")
        assert old.status == "finished" and old.outcome is None
        assert store.read("r-0000000000c8").tolist() == [[0.5, 1.0, 0.0], [0.5, 2.0, 0.1]]
        marks = [{"kind": "saturated", "k": 1, "t": 0.001, "text": "u sat"}]
        store.set_status("r-0000000000c8", "finished", outcome=marks)
        assert store.get_run("r-0000000000c8").outcome == marks
        assert store.list_runs()[0][0].outcome == marks
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    conn.close()
