"""What every part of :class:`~elab.store.sqlite.SQLiteStore` stands on: the file opened
(and migrated) with one connection for writes and one for reads, each behind its own
lock; a write transaction, a read snapshot, SQLite's errors as
:class:`~elab.store.base.StoreError`; and what the tables share (JSON columns, newest
first)."""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType
from typing import Any, Self

from elab.errors import InvalidInput
from elab.store import _db
from elab.store.base import StoreError

NEWEST_FIRST = "ORDER BY created_at DESC, rowid DESC"
_TRANSIENT = ("SQLITE_BUSY", "SQLITE_LOCKED")


class SQLiteConnections:
    """The file's two connections, and the transactions the tables' methods run in."""

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

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

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


def json_column(field: str, value: dict[str, Any] | list[Any]) -> str:
    try:
        return json.dumps(value, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise InvalidInput(
            field, value, f"JSON-able values: finite numbers, strings, lists, dicts ({e})"
        ) from None
