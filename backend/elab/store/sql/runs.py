"""Runs, their parameter changes and their samples (the :class:`~elab.store.base.RunStore`
part of either store): each chunk of a recording is one row of ``chunks`` holding the raw
little-endian float64 bytes of its rows (C order)."""

from __future__ import annotations

import json
import time
from typing import Any

import numpy as np

from elab.errors import Conflict, DimensionError, ElabError, InvalidInput, NotFound
from elab.lifecycle import RunState
from elab.store.base import Array, ParamChange, RunRecord, RunSummary, Usage
from elab.store.sql.tables import NEWEST_FIRST, Conn, Tables, json_column, message, text

_SUMMARY = (
    "id, plant, mode, experiment, status, Ts, channels, n_planned, n_stored, "
    "created_at, started_at, finished_at, error, engine, owner, private, compute, outcome"
)
_COLUMNS = _SUMMARY + ", spec"
# the chunk holding ``start`` and every later one starting before ``stop`` (their rows:
# the bytes wanted are read from the blob, not the whole blob)
_OVERLAPPING = """SELECT rowid, run_id, k0, n FROM chunks
    WHERE run_id = :id AND k0 < :stop AND k0 >= coalesce(
        (SELECT k0 FROM chunks WHERE run_id = :id AND k0 <= :start ORDER BY k0 DESC LIMIT 1),
        0)
    ORDER BY k0"""
_LIVE = tuple(s.value for s in RunState if s.live)


class Runs(Tables):
    """Runs, parameter changes and samples."""

    # -- runs ------------------------------------------------------------------
    def create_run(self, record: RunRecord) -> None:
        if record.n_stored != 0:
            raise InvalidInput("n_stored", record.n_stored, "0 for a new run (the store counts)")
        if not record.channels:
            raise InvalidInput("channels", record.channels, "at least one (name, unit) pair")
        row = (
            text("id", record.id),
            text("plant", record.plant),
            text("mode", record.mode),
            text("experiment", record.experiment),
            _status(record.status),
            record.Ts,
            json.dumps([list(c) for c in record.channels]),
            record.n_planned,
            0,
            record.created_at,
            record.started_at,
            record.finished_at,
            message(record.error),
            None if record.engine is None else text("engine", record.engine),
            None if record.owner is None else text("owner", record.owner),
            int(record.private),
            None if record.compute is None else json_column("compute", record.compute),
            None if record.outcome is None else json_column("outcome", record.outcome),
            json_column("spec", record.spec),
        )
        with self._transaction() as conn:
            try:
                conn.execute(f"INSERT INTO runs ({_COLUMNS}) VALUES ({', '.join('?' * 19)})", row)
            except self.Duplicate:
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
        outcome: list[dict[str, Any]] | None = None,
    ) -> None:
        given = {
            "started_at": started_at,
            "finished_at": finished_at,
            "error": message(error),
            "compute": None if compute is None else json_column("compute", compute),
            "outcome": None if outcome is None else json_column("outcome", outcome),
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
                f"SELECT {_SUMMARY} FROM runs {where} {NEWEST_FIRST} LIMIT ? OFFSET ?",
                (*args, limit, offset),
            ).fetchall()
        return [RunSummary(**_summary_fields(r)) for r in rows], int(total)

    def delete_run(self, run_id: str) -> None:
        with self._transaction() as conn:
            row = conn.execute(
                f"SELECT status FROM runs WHERE id = ?{self.LOCK_ROWS}", (run_id,)
            ).fetchone()
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
                f"SELECT count(*), coalesce(sum(n_stored * {self.CHANNEL_COUNT}), 0) "
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
                (RunState.INTERRUPTED.value, time.time(), message(reason), engine, *_LIVE),
            )
        return ids

    # -- parameter changes -----------------------------------------------------
    def add_param_change(self, run_id: str, change: ParamChange) -> None:
        if change.k < 0:
            raise InvalidInput("k", change.k, "a sample index >= 0")
        params = json_column("params", change.params)
        with self._transaction() as conn:
            run_size(conn, run_id)
            conn.execute(
                "INSERT INTO param_changes (run_id, k, at, params) VALUES (?, ?, ?, ?)",
                (run_id, change.k, change.at, params),
            )

    def param_changes(self, run_id: str) -> list[ParamChange]:
        with self._snapshot() as conn:
            run_size(conn, run_id)
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

    def _sizes(self, conn: Conn, run_ids: list[str]) -> dict[str, tuple[int, int]]:
        """``run id → (n_stored, channels)``, in one query per 500 runs; a run's channels
        never change, so they are parsed once."""
        out: dict[str, tuple[int, int]] = {}
        wanted = list(dict.fromkeys(run_ids))
        for i in range(0, len(wanted), 500):
            part = wanted[i : i + 500]
            marks = ",".join("?" * len(part))
            for run_id, n_stored, channels in conn.execute(
                f"SELECT id, n_stored, channels FROM runs WHERE id IN ({marks}){self.LOCK_ROWS}",
                part,
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
            n_stored, nch = run_size(conn, run_id)
            stop = n_stored if k1 is None else min(k1, n_stored)
            start = min(k0, stop)
            out = np.empty((stop - start, nch), dtype=np.float64)
            filled = 0
            if stop > start:
                width = 8 * nch  # bytes per row
                for rowid, _, c0, n in conn.execute(
                    _OVERLAPPING, {"id": run_id, "start": start, "stop": stop}
                ):
                    lo, hi = max(start, c0), min(stop, c0 + n)
                    # only rows lo..hi of the chunk: a fast run's chunk holds 200,000 rows
                    # (14 MiB), a download reads 8,192 at a time
                    whole, part = self._chunk_part(
                        conn, (rowid, run_id, c0), (lo - c0) * width, (hi - lo) * width
                    )
                    if whole != n * width:
                        raise ElabError(
                            f"{self.where}: run {run_id!r}'s chunk at {c0} holds "
                            f"{whole} bytes, not {n} rows of {nch}; the store is damaged"
                        )
                    rows = np.frombuffer(part, dtype="<f8")
                    out[lo - start : hi - start] = rows.reshape(hi - lo, nch)
                    filled += hi - lo
        if filled != stop - start:
            raise ElabError(
                f"{self.where}: run {run_id!r} has {stop - start - filled} of samples "
                f"[{start}, {stop}) missing; the store is damaged"
            )
        return out


def run_size(conn: Conn, run_id: str) -> tuple[int, int]:
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
        outcome,
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
        "outcome": None if outcome is None else json.loads(outcome),
    }


def _status(status: str) -> str:
    try:
        return RunState(status).value
    except ValueError:
        allowed = ", ".join(s.value for s in RunState)
        raise InvalidInput("status", status, f"one of: {allowed}") from None
