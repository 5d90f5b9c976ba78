"""Runs, their parameter changes and their samples in one SQLite file.

A run's recording is a float64 array ``(n, nch)`` whose columns are the run's
channels (``r, u, y…, x…``); row ``k`` is sample ``k`` at time ``k·Ts``. It
arrives in consecutive chunks, each stored as one row of ``chunks`` holding the
raw little-endian float64 bytes of its rows (C order).

Durability: WAL journal, ``synchronous = NORMAL``. Every committed transaction
survives a crash of the process (``kill -9``); a power cut may lose the last
transactions, never the file's consistency (see :mod:`elab.runs._db`).

Threads: one connection for writes and one for reads, each behind its own lock,
so a reader sees the last committed state while the writer thread appends.
"""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elab.errors import Conflict, DimensionError, ElabError, InvalidInput, NotFound
from elab.runs._db import Checkpointer, connect, migrate
from elab.runs.state import RunState

Array = NDArray[np.float64]

_COLUMNS = ("id, plant, mode, experiment, spec, status, Ts, channels, n_planned, n_stored, "
            "created_at, started_at, finished_at, error")
_NEWEST_FIRST = "ORDER BY created_at DESC, rowid DESC"
# the chunk holding ``start`` and every later one starting before ``stop``
_OVERLAPPING = """SELECT k0, n, data FROM chunks
    WHERE run_id = :id AND k0 < :stop AND k0 >= coalesce(
        (SELECT k0 FROM chunks WHERE run_id = :id AND k0 <= :start ORDER BY k0 DESC LIMIT 1),
        0)
    ORDER BY k0"""
_LIVE = tuple(s.value for s in RunState if s.live)


@dataclass(frozen=True)
class RunRecord:
    """What the store keeps about a run besides its samples (times in unix seconds)."""

    id: str
    plant: str
    mode: str  # "simulation" | "rig"
    experiment: str  # "analysis" | "identification" | "design"
    spec: dict[str, Any]  # the run request, JSON-able
    status: str  # a RunState value
    Ts: float  # s
    channels: tuple[tuple[str, str], ...]  # (name, unit) of the recorded columns
    n_planned: int  # samples of the run if it completes
    n_stored: int = 0  # samples stored so far (maintained by the store)
    created_at: float = 0.0
    started_at: float | None = None
    finished_at: float | None = None
    error: str | None = None


@dataclass(frozen=True)
class ParamChange:
    """New parameters of a run, in force from sample ``k`` on (``at`` in unix seconds)."""

    k: int
    params: dict[str, Any]  # JSON-able
    at: float


class Store:
    """Runs, parameter changes and samples in one SQLite file (WAL mode)."""

    def __init__(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._writer = connect(path)
        migrate(self._writer, path)
        self._reader = connect(path)
        self._checkpointer = Checkpointer(path)
        self._write_lock = threading.Lock()
        self._read_lock = threading.Lock()
        self._channel_counts: dict[str, int] = {}  # run id → channels (used by the writer)

    def close(self) -> None:
        with self._write_lock, self._read_lock:
            self._checkpointer.close()
            self._reader.close()
            self._writer.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # -- runs ------------------------------------------------------------------
    def create_run(self, record: RunRecord) -> None:
        if record.n_stored != 0:
            raise InvalidInput("n_stored", record.n_stored, "0 for a new run (the store counts)")
        if not record.channels:
            raise InvalidInput("channels", record.channels, "at least one (name, unit) pair")
        row = (record.id, record.plant, record.mode, record.experiment,
               _json("spec", record.spec), _status(record.status), record.Ts,
               json.dumps([list(c) for c in record.channels]), record.n_planned, 0,
               record.created_at, record.started_at, record.finished_at, record.error)
        with self._transaction() as conn:
            try:
                conn.execute(f"INSERT INTO runs ({_COLUMNS}) VALUES ({', '.join('?' * 14)})", row)
            except sqlite3.IntegrityError:
                raise Conflict(f"run {record.id!r} already exists; choose another id") from None

    def set_status(self, run_id: str, status: str, *, started_at: float | None = None,
                   finished_at: float | None = None, error: str | None = None) -> None:
        """Set ``status`` and those of the other fields that are given."""
        given = {"started_at": started_at, "finished_at": finished_at, "error": error}
        values = {"status": _status(status)} | {k: v for k, v in given.items() if v is not None}
        sets = ", ".join(f"{k} = :{k}" for k in values)
        with self._transaction() as conn:
            cur = conn.execute(f"UPDATE runs SET {sets} WHERE id = :id", values | {"id": run_id})
            if cur.rowcount == 0:
                raise NotFound("run", run_id)

    def get_run(self, run_id: str) -> RunRecord:
        with self._snapshot() as conn:
            row = conn.execute(f"SELECT {_COLUMNS} FROM runs WHERE id = ?", (run_id,)).fetchone()
        if row is None:
            raise NotFound("run", run_id)
        return _record(row)

    def list_runs(self, *, plant: str | None = None, limit: int = 50,
                  offset: int = 0) -> tuple[list[RunRecord], int]:
        """A page of runs, newest first, and how many runs match in all."""
        if limit < 0:
            raise InvalidInput("limit", limit, "an integer >= 0")
        if offset < 0:
            raise InvalidInput("offset", offset, "an integer >= 0")
        where, args = ("WHERE plant = ?", (plant,)) if plant is not None else ("", ())
        with self._snapshot() as conn:
            total = conn.execute(f"SELECT count(*) FROM runs {where}", args).fetchone()[0]
            rows = conn.execute(f"SELECT {_COLUMNS} FROM runs {where} {_NEWEST_FIRST} "
                                "LIMIT ? OFFSET ?", (*args, limit, offset)).fetchall()
        return [_record(r) for r in rows], int(total)

    def mark_interrupted(self) -> list[str]:
        """At start-up: every run still created, running or paused becomes interrupted."""
        marks = ", ".join("?" * len(_LIVE))
        with self._transaction() as conn:
            ids = [r[0] for r in conn.execute(
                f"SELECT id FROM runs WHERE status IN ({marks}) ORDER BY created_at", _LIVE)]
            conn.execute(f"UPDATE runs SET status = ?, finished_at = ? WHERE status IN ({marks})",
                         (RunState.INTERRUPTED.value, time.time(), *_LIVE))
        return ids

    # -- parameter changes -----------------------------------------------------
    def add_param_change(self, run_id: str, change: ParamChange) -> None:
        if change.k < 0:
            raise InvalidInput("k", change.k, "a sample index >= 0")
        params = _json("params", change.params)
        with self._transaction() as conn:
            _size(conn, run_id)
            conn.execute("INSERT INTO param_changes (run_id, k, at, params) VALUES (?, ?, ?, ?)",
                         (run_id, change.k, change.at, params))

    def param_changes(self, run_id: str) -> list[ParamChange]:
        """The run's parameter changes ordered by ``k`` (then by arrival)."""
        with self._snapshot() as conn:
            _size(conn, run_id)
            rows = conn.execute("SELECT k, params, at FROM param_changes WHERE run_id = ? "
                                "ORDER BY k, rowid", (run_id,)).fetchall()
        return [ParamChange(k, json.loads(p), at) for k, p, at in rows]

    # -- samples ---------------------------------------------------------------
    def append(self, run_id: str, k0: int, data: Array) -> None:
        """Store rows ``k0 .. k0+n-1``; ``k0`` must be the number of samples stored."""
        self.append_many([(run_id, k0, data)])

    def append_many(self, items: list[tuple[str, int, Array]]) -> None:
        """Store several chunks (of any runs, in order) in one transaction: all or none."""
        sizes: dict[str, tuple[int, int]] = {}
        with self._transaction() as conn:
            for run_id, k0, data in items:
                n_stored, nch = sizes.get(run_id) or self._size(conn, run_id)
                if k0 != n_stored:
                    raise InvalidInput("k0", k0, f"{n_stored}, the next sample of run {run_id!r}"
                                       f" (chunks are consecutive; expected {n_stored})")
                if data.ndim != 2 or data.shape[1] != nch:
                    raise DimensionError("data", data.shape,
                                         f"shape (n, {nch}), one column per channel of {run_id}")
                n = data.shape[0]
                sizes[run_id] = (k0 + n, nch)
                if n == 0:
                    continue
                conn.execute("INSERT INTO chunks (run_id, k0, n, data) VALUES (?, ?, ?, ?)",
                             (run_id, k0, n, np.ascontiguousarray(data, dtype="<f8").data))
            conn.executemany("UPDATE runs SET n_stored = ? WHERE id = ?",
                             [(n, run_id) for run_id, (n, _) in sizes.items()])

    def _size(self, conn: sqlite3.Connection, run_id: str) -> tuple[int, int]:
        """``(n_stored, channels)``; a run's channels never change, so they are read once."""
        nch = self._channel_counts.get(run_id)
        if nch is None:
            n_stored, nch = _size(conn, run_id)
            self._channel_counts[run_id] = nch
            return n_stored, nch
        row = conn.execute("SELECT n_stored FROM runs WHERE id = ?", (run_id,)).fetchone()
        if row is None:
            raise NotFound("run", run_id)
        return int(row[0]), nch

    def read(self, run_id: str, k0: int = 0, k1: int | None = None) -> Array:
        """Rows ``[k0, min(k1, n_stored))`` as a new ``(n, nch)`` array (``n`` may be 0)."""
        if k0 < 0:
            raise InvalidInput("k0", k0, "a sample index >= 0")
        with self._snapshot() as conn:
            n_stored, nch = _size(conn, run_id)
            stop = n_stored if k1 is None else min(k1, n_stored)
            start = min(k0, stop)
            out = np.empty((stop - start, nch), dtype=np.float64)
            filled = 0
            if stop > start:
                for c0, n, blob in conn.execute(_OVERLAPPING,
                                                {"id": run_id, "start": start, "stop": stop}):
                    lo, hi = max(start, c0), min(stop, c0 + n)
                    chunk = np.frombuffer(blob, dtype="<f8").reshape(n, nch)
                    out[lo - start:hi - start] = chunk[lo - c0:hi - c0]
                    filled += hi - lo
        if filled != stop - start:
            raise ElabError(f"{self.path}: run {run_id!r} has {stop - start - filled} of samples "
                            f"[{start}, {stop}) missing; the file is damaged")
        return out

    # -- connections -----------------------------------------------------------
    @contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        with self._write_lock:
            conn = self._writer
            conn.execute("BEGIN IMMEDIATE")
            try:
                yield conn
            except BaseException:
                if conn.in_transaction:  # SQLite may have rolled back already (disk full)
                    conn.execute("ROLLBACK")
                raise
            conn.execute("COMMIT")
        self._checkpointer.poke()

    @contextmanager
    def _snapshot(self) -> Iterator[sqlite3.Connection]:
        """One read transaction: every query inside sees the same committed state."""
        with self._read_lock:
            conn = self._reader
            conn.execute("BEGIN")
            try:
                yield conn
            finally:
                conn.execute("COMMIT")


def _size(conn: sqlite3.Connection, run_id: str) -> tuple[int, int]:
    """``(n_stored, number of channels)`` of a run."""
    row = conn.execute("SELECT n_stored, channels FROM runs WHERE id = ?", (run_id,)).fetchone()
    if row is None:
        raise NotFound("run", run_id)
    return int(row[0]), len(json.loads(row[1]))


def _record(row: tuple[Any, ...]) -> RunRecord:
    (id_, plant, mode, experiment, spec, status, Ts, channels, n_planned, n_stored,
     created_at, started_at, finished_at, error) = row
    return RunRecord(id_, plant, mode, experiment, json.loads(spec), status, Ts,
                     tuple((name, unit) for name, unit in json.loads(channels)), n_planned,
                     n_stored, created_at, started_at, finished_at, error)


def _status(status: str) -> str:
    try:
        return RunState(status).value
    except ValueError:
        allowed = ", ".join(s.value for s in RunState)
        raise InvalidInput("status", status, f"one of: {allowed}") from None


def _json(field: str, value: dict[str, Any]) -> str:
    try:
        return json.dumps(value, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise InvalidInput(field, value, f"JSON-able values: finite numbers, strings, lists, "
                           f"dicts ({e})") from None
