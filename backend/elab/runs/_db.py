"""The SQLite file under :mod:`elab.runs.store`: schema, connections, checkpoints.

Pages are 64 KiB so that a typical chunk (a few thousand float64 values) sits
in one page instead of a chain of overflow pages; this makes appending several
times faster. Committed pages go to the write-ahead log; a background thread
copies them into the database file (a *checkpoint*), so a committing thread
never pays for that copy and its ``fsync``.
"""

from __future__ import annotations

import sqlite3
import threading
from pathlib import Path

from elab.errors import ElabError

SCHEMA_VERSION = 1
PAGE_SIZE = 65536  # bytes; takes effect only when the file is created
_SAFETY_CHECKPOINT = 1024  # pages: a writer checkpoints itself if the WAL grows past this
_SCHEMA = (
    """CREATE TABLE runs (
        id TEXT PRIMARY KEY, plant TEXT NOT NULL, mode TEXT NOT NULL,
        experiment TEXT NOT NULL, spec TEXT NOT NULL, status TEXT NOT NULL,
        Ts REAL NOT NULL, channels TEXT NOT NULL, n_planned INTEGER NOT NULL,
        n_stored INTEGER NOT NULL, created_at REAL NOT NULL, started_at REAL,
        finished_at REAL, error TEXT)""",
    "CREATE INDEX runs_by_created ON runs (created_at)",
    "CREATE INDEX runs_by_plant ON runs (plant, created_at)",
    """CREATE TABLE param_changes (
        run_id TEXT NOT NULL REFERENCES runs (id), k INTEGER NOT NULL,
        at REAL NOT NULL, params TEXT NOT NULL)""",
    "CREATE INDEX param_changes_by_run ON param_changes (run_id, k)",
    """CREATE TABLE chunks (
        run_id TEXT NOT NULL REFERENCES runs (id), k0 INTEGER NOT NULL,
        n INTEGER NOT NULL, data BLOB NOT NULL, PRIMARY KEY (run_id, k0))""",
)


def connect(path: Path) -> sqlite3.Connection:
    """A connection in WAL mode, usable from any one thread at a time (the caller locks).

    Transactions are begun and ended explicitly (``isolation_level=None``).
    """
    conn = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    conn.execute(f"PRAGMA page_size = {PAGE_SIZE}")  # before WAL: a new file only
    conn.execute("PRAGMA journal_mode = WAL")
    conn.execute("PRAGMA synchronous = NORMAL")
    conn.execute("PRAGMA busy_timeout = 5000")
    conn.execute("PRAGMA foreign_keys = ON")
    conn.execute(f"PRAGMA wal_autocheckpoint = {_SAFETY_CHECKPOINT}")
    return conn


def migrate(conn: sqlite3.Connection, path: Path) -> None:
    """Create the schema in a new file; refuse a file of another schema version."""
    conn.execute("BEGIN IMMEDIATE")
    try:
        version = conn.execute("PRAGMA user_version").fetchone()[0]
        if version == 0:
            for statement in _SCHEMA:
                conn.execute(statement)
            conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
        elif version != SCHEMA_VERSION:
            raise ElabError(f"{path}: store schema version {version}; this E-Lab reads version "
                            f"{SCHEMA_VERSION} only (use a matching E-Lab or another file)")
    except BaseException:
        if conn.in_transaction:
            conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")


class Checkpointer:
    """Copies committed WAL frames into the database file in a background thread.

    ``poke()`` after a commit; a passive checkpoint waits for no reader or writer.
    """

    def __init__(self, path: Path) -> None:
        self._conn = connect(path)
        self._due = threading.Event()
        self._closing = False
        self._thread = threading.Thread(target=self._loop, name="elab-store-checkpoint",
                                        daemon=True)
        self._thread.start()

    def poke(self) -> None:
        self._due.set()

    def close(self) -> None:
        self._closing = True
        self._due.set()
        self._thread.join()
        self._conn.close()

    def _loop(self) -> None:
        while True:
            self._due.wait()
            self._due.clear()
            if self._closing:
                return
            self._conn.execute("PRAGMA wal_checkpoint(PASSIVE)")
