"""The SQLite run store keeps runs, parameter changes and samples exactly, across threads,
reopenings, a killed process and schema versions (real SQLite files in ``tmp_path``; no
mocks)."""

from __future__ import annotations

import sqlite3
import subprocess
import sys
import threading
from collections.abc import Iterator
from itertools import accumulate, islice
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from elab.errors import Conflict, DimensionError, ElabError, InvalidInput, NotFound
from elab.store import ParamChange, RunRecord, SQLiteStore, Store

CHANNELS = (("r", "rad"), ("u", "V"), ("theta", "rad"), ("alpha", "rad"), ("x_theta", "rad"))
NCH = len(CHANNELS)
ROOT = Path(__file__).resolve().parents[3]


def record(
    run_id: str,
    *,
    plant: str = "flexible_link",
    status: str = "running",
    created_at: float = 1.7e9,
    **kw: Any,
) -> RunRecord:
    return RunRecord(
        id=run_id,
        plant=plant,
        mode="simulation",
        experiment="analysis",
        spec={
            "plant": plant,
            "signal": {"kind": "square", "amplitude": 0.5},
            "K": [1.5, -2.0, 0.25, 1e-3],
        },
        status=status,
        Ts=1e-3,
        channels=CHANNELS,
        n_planned=10_000,
        created_at=created_at,
        **{"engine": "sim-0", **kw},
    )


def chunks(seed: int, sizes: tuple[int, int] = (20, 400)) -> Iterator[np.ndarray]:
    """Endless chunks of random sizes and values (also used by the killed process)."""
    rng = np.random.default_rng(seed)
    while True:
        yield rng.standard_normal((int(rng.integers(*sizes)), NCH)) * 10.0 ** rng.integers(-5, 5)


def fill(store: Store, run_id: str, parts: list[np.ndarray]) -> np.ndarray:
    k = 0
    for data in parts:
        store.append(run_id, k, data)
        k += data.shape[0]
    return np.concatenate(parts)


# -- runs ----------------------------------------------------------------------
def test_a_created_run_reads_back_equal(store: Store) -> None:
    rec = record("r-3f2a9c1b", started_at=1.7e9 + 0.5)
    store.create_run(rec)
    assert store.get_run("r-3f2a9c1b") == rec


def test_a_run_id_is_used_once(store: Store) -> None:
    store.create_run(record("r-1"))
    with pytest.raises(Conflict, match="r-1"):
        store.create_run(record("r-1", plant="belt_conveyor"))


@pytest.mark.parametrize(
    "call",
    [
        lambda s: s.get_run("r-nope"),
        lambda s: s.set_status("r-nope", "stopped"),
        lambda s: s.append("r-nope", 0, np.zeros((3, NCH))),
        lambda s: s.read("r-nope"),
        lambda s: s.add_param_change("r-nope", ParamChange(0, {}, 0.0)),
        lambda s: s.param_changes("r-nope"),
    ],
)
def test_an_unknown_run_is_not_found(store: Store, call: Any) -> None:
    store.create_run(record("r-1"))
    with pytest.raises(NotFound, match="unknown run 'r-nope'"):
        call(store)


def test_status_must_be_a_run_state(store: Store) -> None:
    with pytest.raises(InvalidInput, match="finished") as err:
        store.create_run(record("r-1", status="done"))
    assert err.value.field == "status"


def test_set_status_updates_only_the_given_fields(store: Store) -> None:
    store.create_run(record("r-1", status="created"))
    store.set_status("r-1", "running", started_at=10.0)
    assert (store.get_run("r-1").started_at, store.get_run("r-1").finished_at) == (10.0, None)
    store.set_status("r-1", "failed", finished_at=12.5, error="diverged at t = 2.5 s")
    got = store.get_run("r-1")
    assert (got.status, got.started_at, got.finished_at, got.error) == (
        "failed",
        10.0,
        12.5,
        "diverged at t = 2.5 s",
    )


def test_runs_are_listed_newest_first_in_pages(store: Store) -> None:
    created = [5.0, 1.0, 3.0, 7.0, 2.0, 6.0, 4.0]
    for i, t in enumerate(created):
        plant = "belt_conveyor" if i % 3 == 0 else "flexible_link"
        store.create_run(record(f"r-{t:g}", plant=plant, created_at=t))
    pages = [store.list_runs(limit=3, offset=o) for o in (0, 3, 6, 9)]
    assert [[r.id for r in page] for page, _ in pages] == [
        ["r-7", "r-6", "r-5"],
        ["r-4", "r-3", "r-2"],
        ["r-1"],
        [],
    ]
    assert {total for _, total in pages} == {7}
    belts, total = store.list_runs(plant="belt_conveyor")
    assert ([r.id for r in belts], total) == (["r-7", "r-5", "r-4"], 3)
    assert store.list_runs(plant="double_pendulum") == ([], 0)


@pytest.mark.parametrize(("kw", "field"), [({"limit": -1}, "limit"), ({"offset": -2}, "offset")])
def test_bad_paging_is_refused(store: Store, kw: dict[str, int], field: str) -> None:
    with pytest.raises(InvalidInput) as err:
        store.list_runs(**kw)
    assert err.value.field == field


def test_mark_interrupted_ends_every_live_run_of_that_engine_only(store: Store) -> None:
    for i, status in enumerate(["created", "running", "paused", "finished", "failed"]):
        store.create_run(record(f"r-{status}", status=status, created_at=float(i)))
    store.create_run(record("r-other", engine="sim-1", created_at=9.0))
    assert store.mark_interrupted("sim-0", "it crashed") == ["r-created", "r-running", "r-paused"]
    runs = {r.id: r for r in store.list_runs()[0]}
    assert [runs[f"r-{s}"].status for s in ("created", "running", "paused", "finished")] == [
        "interrupted"
    ] * 3 + ["finished"]
    assert runs["r-running"].finished_at is not None and runs["r-finished"].finished_at is None
    assert runs["r-running"].error == "it crashed" and runs["r-finished"].error is None
    assert runs["r-other"].status == "running"  # another engine's run is its own business
    assert store.mark_interrupted("sim-0", "again") == []


# -- parameter changes ---------------------------------------------------------
def test_parameter_changes_come_back_ordered_by_k(store: Store) -> None:
    store.create_run(record("r-1"))
    changes = [
        ParamChange(4000, {"controller": {"K": [1.0, 2.5]}}, 3.0),
        ParamChange(1200, {"signal": {"amplitude": 0.25}}, 1.0),
        ParamChange(1200, {"signal": {"amplitude": 0.5}}, 2.0),
    ]
    for c in changes:
        store.add_param_change("r-1", c)
    assert store.param_changes("r-1") == [changes[1], changes[2], changes[0]]


def test_parameters_must_be_json(store: Store) -> None:
    store.create_run(record("r-1"))
    with pytest.raises(InvalidInput) as err:
        store.add_param_change("r-1", ParamChange(3, {"K": float("nan")}, 0.0))
    assert err.value.field == "params"


# -- samples -------------------------------------------------------------------
SIZES = [int(n) for n in np.random.default_rng(11).integers(1, 90, size=25)]
BOUNDS = list(accumulate(SIZES))
N = BOUNDS[-1]


@pytest.fixture
def filled(store: Store) -> tuple[Store, np.ndarray]:
    rng = np.random.default_rng(12)
    store.create_run(record("r-1"))
    return store, fill(store, "r-1", [rng.standard_normal((n, NCH)) for n in SIZES])


@pytest.mark.parametrize(
    ("k0", "k1"),
    [
        (0, None),
        (0, N),
        (0, 0),
        (7, 7),
        (0, 1),
        (BOUNDS[0], BOUNDS[0] + 1),
        (BOUNDS[2] - 1, BOUNDS[2] + 1),
        (BOUNDS[3], BOUNDS[9]),
        (BOUNDS[3] + 1, BOUNDS[9] - 1),
        (N - 3, N + 100),
        (N, None),
        (N + 5, N + 10),
        (30, 20),
    ],
)
def test_any_range_reads_back_exactly(
    filled: tuple[Store, np.ndarray], k0: int, k1: int | None
) -> None:
    store, source = filled
    got = store.read("r-1", k0, k1)
    assert got.dtype == np.float64 and got.shape[1] == NCH
    assert np.array_equal(got, source[k0:k1][: max(0, (k1 if k1 is not None else N) - k0)])


def test_a_few_rows_of_a_long_chunk_read_back_exactly_in_any_part(store: Store) -> None:
    """A fast run writes chunks of 200,000 rows; a download reads a few thousand at a
    time, from inside one (only those rows' bytes are read from the blob)."""
    rng = np.random.default_rng(13)
    store.create_run(record("r-1"))
    source = fill(store, "r-1", [rng.standard_normal((n, NCH)) for n in (5_000, 20_000, 3)])
    for k0 in range(0, 25_003, 997):
        assert np.array_equal(store.read("r-1", k0, k0 + 1_234), source[k0 : k0 + 1_234])


def test_a_chunk_shorter_than_its_rows_is_a_damaged_file_not_wrong_numbers(
    store: Store,
) -> None:
    store.create_run(record("r-1"))
    fill(store, "r-1", [np.ones((10, NCH)), np.ones((10, NCH))])
    cut = "UPDATE chunks SET data = substr(data, 1, 8) WHERE k0 = 10"  # (a damaged disk)
    if isinstance(store, SQLiteStore):
        with sqlite3.connect(store.path) as db:
            db.execute(cut)
    else:
        with store._transaction() as conn:  # type: ignore[attr-defined]
            conn.execute(cut)
    with pytest.raises(ElabError, match=r"chunk at 10 holds 8 bytes.*damaged"):
        store.read("r-1", 12, 15)


def test_n_stored_counts_the_appended_samples(filled: tuple[Store, np.ndarray]) -> None:
    store, _ = filled
    assert store.get_run("r-1").n_stored == N


def test_a_run_without_samples_reads_as_an_empty_array(store: Store) -> None:
    store.create_run(record("r-1"))
    store.append("r-1", 0, np.zeros((0, NCH)))
    assert store.read("r-1").shape == (0, NCH) and store.get_run("r-1").n_stored == 0


@pytest.mark.parametrize("k0", [0, 5, 11])
def test_a_chunk_must_start_where_the_stored_samples_end(store: Store, k0: int) -> None:
    store.create_run(record("r-1"))
    store.append("r-1", 0, np.ones((10, NCH)))
    with pytest.raises(ValueError, match=rf"k0: got {k0}; allowed: 10.*expected 10"):
        store.append("r-1", k0, np.ones((4, NCH)))
    assert store.get_run("r-1").n_stored == 10


def test_a_chunk_has_one_column_per_channel(store: Store) -> None:
    store.create_run(record("r-1"))
    with pytest.raises(DimensionError, match=f"shape \\(n, {NCH}\\)"):
        store.append("r-1", 0, np.ones((4, NCH + 1)))


def test_read_refuses_a_negative_start(filled: tuple[Store, np.ndarray]) -> None:
    with pytest.raises(InvalidInput) as err:
        filled[0].read("r-1", -1)
    assert err.value.field == "k0"


def test_append_many_stores_chunks_of_several_runs_in_one_call(store: Store) -> None:
    rng = np.random.default_rng(13)
    for rid in ("r-a", "r-b", "r-c"):
        store.create_run(record(rid))
    a = [rng.standard_normal((n, NCH)) for n in (30, 1, 250)]
    b = [rng.standard_normal((n, NCH)) for n in (40, 60)]
    store.append_many(
        [
            ("r-a", 0, a[0]),
            ("r-b", 0, b[0]),
            ("r-a", 30, a[1]),
            ("r-b", 40, b[1]),
            ("r-a", 31, a[2]),
        ]
    )
    assert np.array_equal(store.read("r-a"), np.concatenate(a))
    assert np.array_equal(store.read("r-b"), np.concatenate(b))
    assert store.read("r-c").shape == (0, NCH)


def test_append_many_stores_all_chunks_or_none(store: Store) -> None:
    store.create_run(record("r-a"))
    store.create_run(record("r-b"))
    with pytest.raises(ValueError, match="r-b"):
        store.append_many([("r-a", 0, np.ones((5, NCH))), ("r-b", 3, np.ones((5, NCH)))])
    assert [store.get_run(r).n_stored for r in ("r-a", "r-b")] == [0, 0]
    store.append("r-a", 0, np.ones((5, NCH)))  # the store is still usable
    assert store.get_run("r-a").n_stored == 5


# -- persistence ---------------------------------------------------------------
def test_everything_is_there_after_reopening(tmp_path: Path) -> None:
    path = tmp_path / "runs.sqlite"
    parts = list(islice(chunks(21), 12))
    change = ParamChange(100, {"controller": {"K": [1.0, 2.0, 3.0, 4.0]}}, 1.7e9 + 0.1)
    with SQLiteStore(path) as store:
        store.create_run(record("r-1"))
        source = fill(store, "r-1", parts)
        store.add_param_change("r-1", change)
        store.set_status("r-1", "finished", finished_at=1.7e9 + 9.0)
        before = store.get_run("r-1")
    with SQLiteStore(path) as store:
        assert store.get_run("r-1") == before
        assert before.n_stored == source.shape[0] and before.status == "finished"
        assert store.param_changes("r-1") == [change]
        assert np.array_equal(store.read("r-1"), source)


def test_a_file_of_another_schema_version_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "future.sqlite"
    with sqlite3.connect(path) as conn:
        conn.execute("PRAGMA user_version = 99")
    conn.close()
    with pytest.raises(ElabError, match="schema version 99"):
        SQLiteStore(path)


# -- a killed writer -----------------------------------------------------------
CHILD = """
import sys
from pathlib import Path
from elab.store import SQLiteStore
from tests.unit.store.test_sqlite import chunks, record

store = SQLiteStore(Path(sys.argv[1]))
store.create_run(record("r-crash"))
k = 0
for data in chunks(seed=31):
    store.append("r-crash", k, data)
    k += data.shape[0]
    print(k, flush=True)
"""


@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL is POSIX")
def test_committed_chunks_survive_a_killed_process(tmp_path: Path) -> None:
    path = tmp_path / "runs.sqlite"
    committed = []
    with subprocess.Popen(
        [sys.executable, "-c", CHILD, str(path)],
        cwd=ROOT,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    ) as proc:
        watchdog = threading.Timer(60.0, proc.kill)
        watchdog.start()
        try:
            assert proc.stdout is not None and proc.stderr is not None
            while len(committed) < 25:
                line = proc.stdout.readline()
                if not line:
                    pytest.fail(f"the writer process ended early:\n{proc.stderr.read()}")
                committed.append(int(line))
        finally:
            proc.kill()  # SIGKILL, mid-way through its appends
            watchdog.cancel()
    assert proc.returncode == -9
    with SQLiteStore(path) as store:
        n = store.get_run("r-crash").n_stored
        assert n >= committed[-1]
        parts = []
        for data in chunks(seed=31):
            parts.append(data)
            if sum(p.shape[0] for p in parts) >= n:
                break
        assert np.array_equal(store.read("r-crash"), np.concatenate(parts)[:n])
        assert store.mark_interrupted("sim-0", "killed") == ["r-crash"]
        assert store.get_run("r-crash").status == "interrupted"


# -- threads -------------------------------------------------------------------
def test_reads_during_appends_see_a_consistent_prefix(store: Store) -> None:
    parts = list(islice(chunks(41, sizes=(20, 300)), 200))
    source = np.concatenate(parts)
    bounds = {0, *accumulate(p.shape[0] for p in parts)}
    store.create_run(record("r-1"))
    failures: list[BaseException] = []

    def writer() -> None:
        try:
            fill(store, "r-1", parts)
        except BaseException as e:  # reported by the main thread
            failures.append(e)

    thread = threading.Thread(target=writer)
    thread.start()
    seen = []
    while thread.is_alive() or not seen:
        n_before = store.get_run("r-1").n_stored
        got = store.read("r-1")
        seen.append(got.shape[0])
        assert got.shape[0] >= n_before and got.shape[0] in bounds
        assert np.array_equal(got, source[: got.shape[0]])
    thread.join()
    assert failures == []
    assert seen == sorted(seen)
    assert np.array_equal(store.read("r-1"), source)
