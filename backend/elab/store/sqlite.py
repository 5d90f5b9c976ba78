"""The embedded store (:class:`~elab.store.base.RunStore` and the other protocols of
:mod:`elab.store.base`): one SQLite file.

Each chunk of a recording is one row of ``chunks`` holding the raw
little-endian float64 bytes of its rows (C order).

Durability: WAL journal, ``synchronous = NORMAL``. Every committed transaction
survives a crash of the process (``kill -9``); a power cut may lose the last
transactions, never the file's consistency (see :mod:`elab.store._db`).

Processes: the web process opens the file first and migrates it; engines open it
after (``migrate=False``) and write their runs; anyone reads. Threads: one
connection for writes and one for reads, each behind its own lock, so a reader
sees the last committed state while a writer appends.

Faults: every :class:`sqlite3.Error` leaves as a
:class:`~elab.store.base.StoreError`; a busy or locked database (another writer
past the busy timeout) is transient, anything else (full, read-only, I/O error,
damaged file) is not.
"""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from elab.errors import Conflict, DimensionError, ElabError, InvalidInput, NotFound
from elab.lifecycle import RunState
from elab.store import _db
from elab.store.base import (
    Array,
    ParamChange,
    Pin,
    RunRecord,
    RunSummary,
    StoredController,
    StoredModel,
    StoreError,
    Token,
    Usage,
)

_SUMMARY = (
    "id, plant, mode, experiment, status, Ts, channels, n_planned, n_stored, "
    "created_at, started_at, finished_at, error, engine, owner, private, compute"
)
_COLUMNS = _SUMMARY + ", spec"
_CONTROLLER = "id, owner, plant, name, format, law, report, created_at"
_MODEL = "id, owner, plant, name, model, created_at"
_NEWEST_FIRST = "ORDER BY created_at DESC, rowid DESC"
# the chunk holding ``start`` and every later one starting before ``stop``
_OVERLAPPING = """SELECT k0, n, data FROM chunks
    WHERE run_id = :id AND k0 < :stop AND k0 >= coalesce(
        (SELECT k0 FROM chunks WHERE run_id = :id AND k0 <= :start ORDER BY k0 DESC LIMIT 1),
        0)
    ORDER BY k0"""
_LIVE = tuple(s.value for s in RunState if s.live)
_TRANSIENT = ("SQLITE_BUSY", "SQLITE_LOCKED")


class SQLiteStore:
    """Runs, parameter changes and samples in one SQLite file (WAL mode)."""

    def __init__(self, path: Path, *, migrate: bool = True, busy_timeout: float = 5.0) -> None:
        """Open (creating if needed) the file; ``migrate``: bring it to this version's
        schema, else refuse a file of another version. A write waits ``busy_timeout``
        seconds for another writer before it fails (transiently)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        with _faults():
            self._writer = _db.connect(path, busy_timeout)
            if migrate:
                _db.migrate(self._writer, path)
            else:
                _db.check_version(self._writer, path)
            self._reader = _db.connect(path)
            self._checkpointer = _db.Checkpointer(path)
        self._write_lock = threading.Lock()
        self._read_lock = threading.Lock()
        self._channel_counts: dict[str, int] = {}  # live run id → channels (the writer's)

    def close(self) -> None:
        with self._write_lock, self._read_lock:
            self._checkpointer.close()
            self._reader.close()
            self._writer.close()

    def __enter__(self) -> SQLiteStore:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- runs ------------------------------------------------------------------
    def create_run(self, record: RunRecord) -> None:
        if record.n_stored != 0:
            raise InvalidInput("n_stored", record.n_stored, "0 for a new run (the store counts)")
        if not record.channels:
            raise InvalidInput("channels", record.channels, "at least one (name, unit) pair")
        row = (
            record.id,
            record.plant,
            record.mode,
            record.experiment,
            _status(record.status),
            record.Ts,
            json.dumps([list(c) for c in record.channels]),
            record.n_planned,
            0,
            record.created_at,
            record.started_at,
            record.finished_at,
            record.error,
            record.engine,
            record.owner,
            int(record.private),
            None if record.compute is None else _json("compute", record.compute),
            _json("spec", record.spec),
        )
        with self._transaction() as conn:
            try:
                conn.execute(f"INSERT INTO runs ({_COLUMNS}) VALUES ({', '.join('?' * 18)})", row)
            except sqlite3.IntegrityError:
                raise Conflict(f"run {record.id!r} already exists; choose another id") from None

    def set_status(
        self,
        run_id: str,
        status: str,
        *,
        started_at: float | None = None,
        finished_at: float | None = None,
        error: str | None = None,
        compute: dict[str, float | int] | None = None,
    ) -> None:
        given = {
            "started_at": started_at,
            "finished_at": finished_at,
            "error": error,
            "compute": None if compute is None else _json("compute", compute),
        }
        values = {"status": _status(status)} | {k: v for k, v in given.items() if v is not None}
        sets = ", ".join(f"{k} = :{k}" for k in values)
        with self._transaction() as conn:
            cur = conn.execute(f"UPDATE runs SET {sets} WHERE id = :id", values | {"id": run_id})
            if cur.rowcount == 0:
                raise NotFound("run", run_id)
        if finished_at is not None:  # its last write: the writer needs its size no more
            self._channel_counts.pop(run_id, None)

    def get_run(self, run_id: str) -> RunRecord:
        with self._snapshot() as conn:
            row = conn.execute(f"SELECT {_COLUMNS} FROM runs WHERE id = ?", (run_id,)).fetchone()
        if row is None:
            raise NotFound("run", run_id)
        return RunRecord(**_summary_fields(row[:-1]), spec=json.loads(row[-1]))

    def list_runs(
        self,
        *,
        plant: str | None = None,
        owner: str | None = None,
        viewer: str | None = None,
        limit: int = 50,
        offset: int = 0,
    ) -> tuple[list[RunSummary], int]:
        if limit < 0:
            raise InvalidInput("limit", limit, "an integer >= 0")
        if offset < 0:
            raise InvalidInput("offset", offset, "an integer >= 0")
        terms: list[str] = []
        args: tuple[Any, ...] = ()
        if plant is not None:
            terms, args = [*terms, "plant = ?"], (*args, plant)
        if owner is not None:
            terms, args = [*terms, "owner = ?"], (*args, owner)
        if viewer is not None:
            terms, args = [*terms, "(private = 0 OR owner = ?)"], (*args, viewer)
        where = "WHERE " + " AND ".join(terms) if terms else ""
        with self._snapshot() as conn:
            total = conn.execute(f"SELECT count(*) FROM runs {where}", args).fetchone()[0]
            rows = conn.execute(
                f"SELECT {_SUMMARY} FROM runs {where} {_NEWEST_FIRST} LIMIT ? OFFSET ?",
                (*args, limit, offset),
            ).fetchall()
        return [RunSummary(**_summary_fields(r)) for r in rows], int(total)

    def delete_run(self, run_id: str) -> None:
        with self._transaction() as conn:
            row = conn.execute("SELECT status FROM runs WHERE id = ?", (run_id,)).fetchone()
            if row is None:
                raise NotFound("run", run_id)
            if row[0] in _LIVE:
                raise Conflict(f"run {run_id} is {row[0]}: stop it before deleting it")
            for table in ("chunks", "param_changes", "pins"):
                conn.execute(f"DELETE FROM {table} WHERE run_id = ?", (run_id,))
            conn.execute("DELETE FROM runs WHERE id = ?", (run_id,))

    def usage(self, owner: str) -> Usage:
        with self._snapshot() as conn:
            runs, values = conn.execute(
                "SELECT count(*), coalesce(sum(n_stored * json_array_length(channels)), 0) "
                "FROM runs WHERE owner = ?",
                (owner,),
            ).fetchone()
        return Usage(int(runs), int(values) * 8)

    def ended_before(self, t: float, limit: int = 100) -> list[str]:
        marks = ", ".join("?" * len(_LIVE))
        with self._snapshot() as conn:
            rows = conn.execute(
                f"SELECT id FROM runs WHERE finished_at < ? AND status NOT IN ({marks}) "
                "AND id NOT IN (SELECT run_id FROM pins) ORDER BY finished_at LIMIT ?",
                (t, *_LIVE, limit),
            ).fetchall()
        return [r[0] for r in rows]

    def mark_interrupted(self, engine: str, reason: str) -> list[str]:
        marks = ", ".join("?" * len(_LIVE))
        mine = f"engine = ? AND status IN ({marks})"
        with self._transaction() as conn:
            ids = [
                r[0]
                for r in conn.execute(
                    f"SELECT id FROM runs WHERE {mine} ORDER BY created_at", (engine, *_LIVE)
                )
            ]
            conn.execute(
                f"UPDATE runs SET status = ?, finished_at = ?, error = ? WHERE {mine}",
                (RunState.INTERRUPTED.value, time.time(), reason, engine, *_LIVE),
            )
        return ids

    # -- parameter changes -----------------------------------------------------
    def add_param_change(self, run_id: str, change: ParamChange) -> None:
        if change.k < 0:
            raise InvalidInput("k", change.k, "a sample index >= 0")
        params = _json("params", change.params)
        with self._transaction() as conn:
            _size(conn, run_id)
            conn.execute(
                "INSERT INTO param_changes (run_id, k, at, params) VALUES (?, ?, ?, ?)",
                (run_id, change.k, change.at, params),
            )

    def param_changes(self, run_id: str) -> list[ParamChange]:
        with self._snapshot() as conn:
            _size(conn, run_id)
            rows = conn.execute(
                "SELECT k, params, at FROM param_changes WHERE run_id = ? ORDER BY k, rowid",
                (run_id,),
            ).fetchall()
        return [ParamChange(k, json.loads(p), at) for k, p, at in rows]

    # -- samples ---------------------------------------------------------------
    def append(self, run_id: str, k0: int, data: Array) -> None:
        """Store rows ``k0 .. k0+n-1``; ``k0`` must be the number of samples stored."""
        self.append_many([(run_id, k0, data)])

    def append_many(self, items: list[tuple[str, int, Array]]) -> None:
        with self._transaction() as conn:
            sizes = self._sizes(conn, [run_id for run_id, _, _ in items])
            rows = []
            for run_id, k0, data in items:
                n_stored, nch = sizes[run_id]
                if k0 != n_stored:
                    raise InvalidInput(
                        "k0",
                        k0,
                        f"{n_stored}, the next sample of run {run_id!r}"
                        f" (chunks are consecutive; expected {n_stored})",
                    )
                if data.ndim != 2 or data.shape[1] != nch:
                    raise DimensionError(
                        "data", data.shape, f"shape (n, {nch}), one column per channel of {run_id}"
                    )
                n = data.shape[0]
                sizes[run_id] = (k0 + n, nch)
                if n:
                    rows.append((run_id, k0, n, np.ascontiguousarray(data, dtype="<f8").data))
            conn.executemany("INSERT INTO chunks (run_id, k0, n, data) VALUES (?, ?, ?, ?)", rows)
            conn.executemany(
                "UPDATE runs SET n_stored = ? WHERE id = ?",
                [(n, run_id) for run_id, (n, _) in sizes.items()],
            )

    def _sizes(self, conn: sqlite3.Connection, run_ids: list[str]) -> dict[str, tuple[int, int]]:
        """``run id → (n_stored, channels)``, in one query per 500 runs; a run's channels
        never change, so they are parsed once."""
        out: dict[str, tuple[int, int]] = {}
        wanted = list(dict.fromkeys(run_ids))
        for i in range(0, len(wanted), 500):
            part = wanted[i : i + 500]
            marks = ",".join("?" * len(part))
            for run_id, n_stored, channels in conn.execute(
                f"SELECT id, n_stored, channels FROM runs WHERE id IN ({marks})", part
            ):
                nch = self._channel_counts.get(run_id)
                if nch is None:
                    nch = self._channel_counts[run_id] = len(json.loads(channels))
                out[run_id] = (int(n_stored), nch)
        for run_id in wanted:
            if run_id not in out:
                raise NotFound("run", run_id)
        return out

    def read(self, run_id: str, k0: int = 0, k1: int | None = None) -> Array:
        if k0 < 0:
            raise InvalidInput("k0", k0, "a sample index >= 0")
        with self._snapshot() as conn:
            n_stored, nch = _size(conn, run_id)
            stop = n_stored if k1 is None else min(k1, n_stored)
            start = min(k0, stop)
            out = np.empty((stop - start, nch), dtype=np.float64)
            filled = 0
            if stop > start:
                for c0, n, blob in conn.execute(
                    _OVERLAPPING, {"id": run_id, "start": start, "stop": stop}
                ):
                    lo, hi = max(start, c0), min(stop, c0 + n)
                    chunk = np.frombuffer(blob, dtype="<f8").reshape(n, nch)
                    out[lo - start : hi - start] = chunk[lo - c0 : hi - c0]
                    filled += hi - lo
        if filled != stop - start:
            raise ElabError(
                f"{self.path}: run {run_id!r} has {stop - start - filled} of samples "
                f"[{start}, {stop}) missing; the file is damaged"
            )
        return out

    # -- uploaded controllers (ControllerStore) ------------------------------------
    def add_controller(self, controller: StoredController) -> None:
        c = controller
        with self._transaction() as conn:
            conn.execute(
                "INSERT INTO controllers (id, owner, plant, name, format, law, report, "
                "source, created_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    c.id,
                    c.owner,
                    c.plant,
                    c.name,
                    c.format,
                    _json("law", c.law),
                    _json("report", c.report),
                    c.source,
                    c.created_at,
                ),
            )

    def get_controller(self, controller_id: str) -> StoredController:
        with self._snapshot() as conn:
            row = conn.execute(
                f"SELECT {_CONTROLLER}, source FROM controllers WHERE id = ?", (controller_id,)
            ).fetchone()
        if row is None:
            raise NotFound("controller", controller_id)
        return _controller(row[:-1], bytes(row[-1]))

    def list_controllers(
        self, owner: str | None, plant: str | None = None
    ) -> list[StoredController]:
        terms = [t for t, v in (("owner = ?", owner), ("plant = ?", plant)) if v is not None]
        args = [v for v in (owner, plant) if v is not None]
        where = "WHERE " + " AND ".join(terms) if terms else ""
        with self._snapshot() as conn:
            rows = conn.execute(
                f"SELECT {_CONTROLLER} FROM controllers {where} "
                "ORDER BY created_at DESC, rowid DESC LIMIT 1000",
                args,
            ).fetchall()
        return [_controller(r) for r in rows]

    def count_controllers(self, owner: str) -> int:
        with self._snapshot() as conn:
            n = conn.execute("SELECT count(*) FROM controllers WHERE owner = ?", (owner,))
            return int(n.fetchone()[0])

    def delete_controller(self, controller_id: str) -> None:
        with self._transaction() as conn:
            cur = conn.execute("DELETE FROM controllers WHERE id = ?", (controller_id,))
            if cur.rowcount == 0:
                raise NotFound("controller", controller_id)

    # -- identified models (ModelStore) -------------------------------------------
    def add_model(self, model: StoredModel) -> None:
        m = model
        row = (m.id, m.owner, m.plant, m.name, _json("model", m.model), m.created_at)
        with self._transaction() as conn:
            try:
                conn.execute(f"INSERT INTO models ({_MODEL}) VALUES (?, ?, ?, ?, ?, ?)", row)
            except sqlite3.IntegrityError:
                raise Conflict(f"model {m.id!r} already exists; choose another id") from None

    def get_model(self, model_id: str) -> StoredModel:
        with self._snapshot() as conn:
            row = conn.execute(f"SELECT {_MODEL} FROM models WHERE id = ?", (model_id,)).fetchone()
        if row is None:
            raise NotFound("model", model_id)
        return _model(row)

    def list_models(self, owner: str | None, plant: str | None = None) -> list[StoredModel]:
        terms = [t for t, v in (("owner = ?", owner), ("plant = ?", plant)) if v is not None]
        args = [v for v in (owner, plant) if v is not None]
        where = "WHERE " + " AND ".join(terms) if terms else ""
        with self._snapshot() as conn:
            rows = conn.execute(
                f"SELECT {_MODEL} FROM models {where} {_NEWEST_FIRST} LIMIT 1000", args
            ).fetchall()
        return [_model(r) for r in rows]

    def count_models(self, owner: str) -> int:
        with self._snapshot() as conn:
            n = conn.execute("SELECT count(*) FROM models WHERE owner = ?", (owner,))
            return int(n.fetchone()[0])

    def delete_model(self, model_id: str) -> None:
        with self._transaction() as conn:
            if conn.execute("DELETE FROM models WHERE id = ?", (model_id,)).rowcount == 0:
                raise NotFound("model", model_id)

    # -- tokens and pins (AccessStore) -------------------------------------------
    def add_token(self, token: Token, digest: str) -> None:
        with self._transaction() as conn:
            conn.execute(
                "INSERT INTO tokens (id, hash, owner, name, created_at, last_used) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (token.id, digest, token.owner, token.name, token.created_at, token.last_used),
            )

    def token_by_digest(self, digest: str) -> Token | None:
        with self._snapshot() as conn:
            row = conn.execute(
                "SELECT id, owner, name, created_at, last_used FROM tokens WHERE hash = ?",
                (digest,),
            ).fetchone()
        return Token(*row) if row else None

    def touch_token(self, token_id: str, at: float) -> None:
        with self._transaction() as conn:
            conn.execute("UPDATE tokens SET last_used = ? WHERE id = ?", (at, token_id))

    def tokens(self, owner: str) -> list[Token]:
        with self._snapshot() as conn:
            rows = conn.execute(
                "SELECT id, owner, name, created_at, last_used FROM tokens WHERE owner = ? "
                "ORDER BY created_at",
                (owner,),
            ).fetchall()
        return [Token(*r) for r in rows]

    def revoke_token(self, owner: str, token_id: str) -> None:
        with self._transaction() as conn:
            cur = conn.execute("DELETE FROM tokens WHERE id = ? AND owner = ?", (token_id, owner))
            if cur.rowcount == 0:
                raise NotFound("token", token_id)

    def end_session(self, sid: str, until: float) -> None:
        with self._transaction() as conn:
            conn.execute("DELETE FROM ended_sessions WHERE until < ?", (time.time(),))
            conn.execute(
                "INSERT OR REPLACE INTO ended_sessions (sid, until) VALUES (?, ?)", (sid, until)
            )

    def ended_sessions(self, now: float) -> set[str]:
        with self._snapshot() as conn:
            rows = conn.execute("SELECT sid FROM ended_sessions WHERE until >= ?", (now,))
            return {sid for (sid,) in rows}

    def set_pin(self, pin: Pin) -> None:
        with self._transaction() as conn:
            _size(conn, pin.run_id)  # NotFound for an unknown run
            conn.execute(
                "INSERT OR REPLACE INTO pins (name, run_id, owner, at) VALUES (?, ?, ?, ?)",
                (pin.name, pin.run_id, pin.owner, pin.at),
            )

    def pin(self, name: str) -> Pin | None:
        with self._snapshot() as conn:
            row = conn.execute(
                "SELECT name, run_id, owner, at FROM pins WHERE name = ?", (name,)
            ).fetchone()
        return Pin(*row) if row else None

    def clear_pin(self, name: str) -> None:
        with self._transaction() as conn:
            conn.execute("DELETE FROM pins WHERE name = ?", (name,))

    # -- health ----------------------------------------------------------------
    def probe(self) -> None:
        with self._transaction() as conn:
            conn.execute("INSERT OR REPLACE INTO probe (id, at) VALUES (1, ?)", (time.time(),))

    # -- connections -----------------------------------------------------------
    @contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        with self._write_lock, _faults():
            conn = self._writer
            conn.execute("BEGIN IMMEDIATE")
            try:
                yield conn
            except BaseException:
                if conn.in_transaction:  # SQLite may have rolled back already (disk full)
                    conn.execute("ROLLBACK")
                raise
            try:
                conn.execute("COMMIT")
            except sqlite3.Error:
                if conn.in_transaction:
                    conn.execute("ROLLBACK")
                raise
        self._checkpointer.poke()

    @contextmanager
    def _snapshot(self) -> Iterator[sqlite3.Connection]:
        """One read transaction: every query inside sees the same committed state."""
        with self._read_lock, _faults():
            conn = self._reader
            conn.execute("BEGIN")
            try:
                yield conn
            finally:
                conn.execute("COMMIT")


@contextmanager
def _faults() -> Iterator[None]:
    """SQLite's errors as :class:`StoreError`, transient or not."""
    try:
        yield
    except sqlite3.Error as exc:
        if isinstance(exc, sqlite3.IntegrityError | sqlite3.ProgrammingError):
            raise  # a bug or a constraint the caller handles, not a fault of the store
        name = getattr(exc, "sqlite_errorname", "") or type(exc).__name__
        transient = name.startswith(_TRANSIENT)
        raise StoreError(f"{exc} ({name})", transient=transient) from exc


def _size(conn: sqlite3.Connection, run_id: str) -> tuple[int, int]:
    """``(n_stored, number of channels)`` of a run."""
    row = conn.execute("SELECT n_stored, channels FROM runs WHERE id = ?", (run_id,)).fetchone()
    if row is None:
        raise NotFound("run", run_id)
    return int(row[0]), len(json.loads(row[1]))


def _summary_fields(row: tuple[Any, ...]) -> dict[str, Any]:
    (
        id_,
        plant,
        mode,
        experiment,
        status,
        Ts,
        channels,
        n_planned,
        n_stored,
        created_at,
        started_at,
        finished_at,
        error,
        engine,
        owner,
        private,
        compute,
    ) = row
    return {
        "id": id_,
        "plant": plant,
        "mode": mode,
        "experiment": experiment,
        "status": status,
        "Ts": Ts,
        "channels": tuple((name, unit) for name, unit in json.loads(channels)),
        "n_planned": n_planned,
        "n_stored": n_stored,
        "created_at": created_at,
        "started_at": started_at,
        "finished_at": finished_at,
        "error": error,
        "engine": engine,
        "owner": owner,
        "private": bool(private),
        "compute": None if compute is None else json.loads(compute),
    }


def _controller(row: tuple[Any, ...], source: bytes = b"") -> StoredController:
    id_, owner, plant, name, fmt, law, report, created_at = row
    return StoredController(
        id_, owner, plant, name, fmt, json.loads(law), json.loads(report), created_at, source
    )


def _model(row: tuple[Any, ...]) -> StoredModel:
    id_, owner, plant, name, model, created_at = row
    return StoredModel(id_, owner, plant, name, json.loads(model), created_at)


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
        raise InvalidInput(
            field, value, f"JSON-able values: finite numbers, strings, lists, dicts ({e})"
        ) from None
