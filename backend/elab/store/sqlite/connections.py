"""The SQLite side of :class:`~elab.store.sql.tables.Tables`: the file opened (and migrated)
with one connection for writes and one for reads, each behind its own lock; a write
transaction (``BEGIN IMMEDIATE``: SQLite's one writer, which also serialises every
read-then-write), a read snapshot, SQLite's errors as :class:`~elab.store.base.StoreError`,
and a chunk's bytes read in place from its blob."""

from __future__ import annotations

import fcntl
import os
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from elab.store import _db
from elab.store.base import StoreError
from elab.store.sql.tables import Conn, Tables, taken

_TRANSIENT = ("SQLITE_BUSY", "SQLITE_LOCKED")


class SQLiteConnections(Tables):
    """The file's two connections, and the transactions the tables' methods run in."""

    Duplicate = sqlite3.IntegrityError
    LOCK_ROWS = ""  # BEGIN IMMEDIATE holds the whole file
    CHANNEL_COUNT = "json_array_length(channels)"

    def __init__(
        self,
        path: Path,
        *,
        migrate: bool = True,
        busy_timeout: float = 5.0,
        claim: str | None = None,
    ) -> None:
        """Open (creating if needed) the file; ``migrate``: bring it to this version's
        schema, else refuse a file of another version. A write waits ``busy_timeout``
        seconds for another writer before it fails (transiently). ``claim``: that name
        first (:meth:`claim`, not waiting), before anything is written to the file."""
        super().__init__(str(path))
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._claims: dict[str, int] = {}  # locked files' descriptors, by name (claim)
        if claim is not None:
            self.claim(claim, 0.0)
        with _faults():
            self._writer = _db.connect(path, busy_timeout)
            if migrate:
                self.migrated_from = _db.migrate(self._writer, path)
            else:
                _db.check_version(self._writer, path)
            self._reader = _db.connect(path)
            self._checkpointer = _db.Checkpointer(path)
        self._write_lock = threading.Lock()
        self._read_lock = threading.Lock()

    def claim(self, name: str, wait: float = 10.0) -> None:
        """An exclusive ``flock`` on ``<file>.<name>.lock`` beside the file: the kernel
        lets go when the process ends, however it ends. A name this store holds already
        is held."""
        if name in self._claims:
            return
        lock = self.path.with_name(f"{self.path.name}.{name}.lock")
        fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o600)
        deadline = time.monotonic() + wait
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() >= deadline:
                    os.close(fd)
                    raise taken(self.where, name) from None
                time.sleep(0.05)
        self._claims[name] = fd

    def close(self) -> None:
        with self._write_lock, self._read_lock:
            self._checkpointer.close()
            self._reader.close()
            self._writer.close()
            while self._claims:
                os.close(self._claims.popitem()[1])

    # -- connections -----------------------------------------------------------
    @contextmanager
    def _transaction(self) -> Iterator[Conn]:
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
    def _snapshot(self) -> Iterator[Conn]:
        with self._read_lock, _faults():
            conn = self._reader
            conn.execute("BEGIN")
            try:
                yield conn
            finally:
                conn.execute("COMMIT")

    def _serialise(self, conn: Conn, key: str) -> None:
        pass  # BEGIN IMMEDIATE took the file's one write lock before anything was read

    def _chunk_part(
        self, conn: Conn, chunk: tuple[Any, ...], at: int, size: int
    ) -> tuple[int, bytes]:
        assert isinstance(conn, sqlite3.Connection)
        with conn.blobopen("chunks", "data", chunk[0], readonly=True) as blob:
            whole = len(blob)
            if at + size > whole:
                return whole, b""  # a damaged file: the caller says so
            blob.seek(at)
            return whole, blob.read(size)


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
