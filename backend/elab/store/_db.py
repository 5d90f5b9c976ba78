"""The SQLite file under :mod:`elab.store.sqlite`: schema and its migrations, connections,
checkpoints.

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

PAGE_SIZE = 65536  # bytes; takes effect only when the file is created
_SAFETY_CHECKPOINT = 1024  # pages: a writer checkpoints itself if the WAL grows past this

#: Schema changes, in order: ``MIGRATIONS[i]`` takes a file from version ``i`` to ``i + 1``.
#: Append only; a released step never changes (a test opens a file of every version).
MIGRATIONS: tuple[tuple[str, ...], ...] = (
    (  # 1: runs, their parameter changes and their samples
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
    ),
    (  # 2: the engine that steps a run (its restart interrupts only its own runs), and a
        # row to write when checking that writing works
        "ALTER TABLE runs ADD COLUMN engine TEXT",
        "CREATE INDEX runs_by_engine ON runs (engine, status)",
        "CREATE TABLE probe (id INTEGER PRIMARY KEY CHECK (id = 1), at REAL NOT NULL)",
    ),
    (  # 3: who owns a run and whether others may see it; API tokens (only their hashes);
        # pinned runs (the class demo)
        "ALTER TABLE runs ADD COLUMN owner TEXT",
        "ALTER TABLE runs ADD COLUMN private INTEGER NOT NULL DEFAULT 0",
        "CREATE INDEX runs_by_owner ON runs (owner, created_at)",
        "CREATE INDEX runs_by_finished ON runs (finished_at)",
        """CREATE TABLE tokens (
            id TEXT PRIMARY KEY, hash TEXT NOT NULL UNIQUE, owner TEXT NOT NULL,
            name TEXT NOT NULL, created_at REAL NOT NULL, last_used REAL)""",
        "CREATE INDEX tokens_by_owner ON tokens (owner, created_at)",
        """CREATE TABLE pins (
            name TEXT PRIMARY KEY, run_id TEXT NOT NULL REFERENCES runs (id),
            owner TEXT NOT NULL, at REAL NOT NULL)""",
    ),
    (  # 4: controllers users upload: the file as sent, the law read from it, its report
        """CREATE TABLE controllers (
            id TEXT PRIMARY KEY, owner TEXT NOT NULL, plant TEXT NOT NULL,
            name TEXT NOT NULL, format TEXT NOT NULL, law TEXT NOT NULL,
            report TEXT NOT NULL, source BLOB NOT NULL, created_at REAL NOT NULL)""",
        "CREATE INDEX controllers_by_owner ON controllers (owner, created_at)",
    ),
    (  # 5: a code controller's compute time per step (JSON), kept when its run ends
        "ALTER TABLE runs ADD COLUMN compute TEXT",
    ),
    (  # 6: identified models users keep for design: the model as JSON (matrices, names)
        """CREATE TABLE models (
            id TEXT PRIMARY KEY, owner TEXT NOT NULL, plant TEXT NOT NULL,
            name TEXT NOT NULL, model TEXT NOT NULL, created_at REAL NOT NULL)""",
        "CREATE INDEX models_by_owner ON models (owner, created_at)",
    ),
    (  # 7: instructors' sessions ended by signing out, kept until they would have expired
        """CREATE TABLE ended_sessions (
            sid TEXT PRIMARY KEY, until REAL NOT NULL)""",
    ),
    (  # 8: the rig queue (elab.rig_queue): a row per rig, its users in order, and its seat,
        # one row per rig (the primary key) and always the user at place 1 (the foreign
        # key): a second driver cannot be written
        """CREATE TABLE rigs (
            rig TEXT PRIMARY KEY, settling INTEGER NOT NULL CHECK (settling IN (0, 1)),
            out_of_service TEXT NOT NULL, updated_at REAL NOT NULL)""",
        """CREATE TABLE rig_queue (
            rig TEXT NOT NULL REFERENCES rigs (rig), place INTEGER NOT NULL CHECK (place >= 1),
            user_id TEXT NOT NULL, PRIMARY KEY (rig, place), UNIQUE (rig, user_id),
            UNIQUE (rig, place, user_id))""",
        """CREATE TABLE rig_seat (
            rig TEXT PRIMARY KEY REFERENCES rigs (rig),
            place INTEGER NOT NULL DEFAULT 1 CHECK (place = 1), user_id TEXT NOT NULL,
            phase TEXT NOT NULL CHECK (phase IN ('seated', 'armed', 'running')),
            since REAL NOT NULL, until REAL NOT NULL, run_id TEXT,
            took_over INTEGER NOT NULL CHECK (took_over IN (0, 1)),
            CHECK ((phase = 'running') = (run_id IS NOT NULL)),
            FOREIGN KEY (rig, place, user_id) REFERENCES rig_queue (rig, place, user_id)
                DEFERRABLE INITIALLY DEFERRED)""",
    ),
    (  # 9: how a run went beyond its state (elab.engines.outcome): its marks as JSON
        "ALTER TABLE runs ADD COLUMN outcome TEXT",
    ),
)
SCHEMA_VERSION = len(MIGRATIONS)


def connect(path: Path, busy_timeout: float = 5.0) -> sqlite3.Connection:
    """A connection in WAL mode, usable from any one thread at a time (the caller locks).

    Transactions are begun and ended explicitly (``isolation_level=None``). A write that
    finds another writer waits up to ``busy_timeout`` seconds, then fails as busy.
    """
    conn = sqlite3.connect(path, isolation_level=None, check_same_thread=False)
    conn.execute(f"PRAGMA page_size = {PAGE_SIZE}")  # before WAL: a new file only
    conn.execute("PRAGMA journal_mode = WAL")
    conn.execute("PRAGMA synchronous = NORMAL")
    conn.execute(f"PRAGMA busy_timeout = {round(busy_timeout * 1000)}")
    conn.execute("PRAGMA foreign_keys = ON")
    conn.execute(f"PRAGMA wal_autocheckpoint = {_SAFETY_CHECKPOINT}")
    return conn


def migrate(conn: sqlite3.Connection, path: Path) -> int:
    """Bring the file to :data:`SCHEMA_VERSION` (a new file gets every step), in one
    transaction; refuse a file written by a newer E-Lab. Returns the version found."""
    conn.execute("BEGIN IMMEDIATE")
    try:
        found = _version(conn, path)
        for step in MIGRATIONS[found:]:
            for statement in step:
                conn.execute(statement)
        conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
    except BaseException:
        if conn.in_transaction:
            conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")
    return found


def check_version(conn: sqlite3.Connection, path: Path) -> None:
    """Refuse a file that is not at :data:`SCHEMA_VERSION` (for processes that do not
    migrate: the engines open a file the web process has migrated)."""
    found = _version(conn, path)
    if found != SCHEMA_VERSION:
        raise ElabError(
            f"{path}: store schema version {found}; this process expects "
            f"{SCHEMA_VERSION} (start the server, which upgrades the file, first)"
        )


def _version(conn: sqlite3.Connection, path: Path) -> int:
    version = int(conn.execute("PRAGMA user_version").fetchone()[0])
    if version > SCHEMA_VERSION:
        raise ElabError(
            f"{path}: store schema version {version} was written by a newer "
            f"E-Lab; this E-Lab reads versions up to {SCHEMA_VERSION}"
        )
    return version


class Checkpointer:
    """Copies committed WAL frames into the database file in a background thread.

    ``poke()`` after a commit; a passive checkpoint waits for no reader or writer. A
    failed checkpoint (the file went read-only, the disk is full) is kept in ``error``
    and tried again at the next poke: the WAL holds the data meanwhile.
    """

    def __init__(self, path: Path) -> None:
        self._conn = connect(path)
        self._due = threading.Event()
        self._closing = False
        self.error: str | None = None
        self._thread = threading.Thread(
            target=self._loop, name="elab-store-checkpoint", daemon=True
        )
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
            try:
                self._conn.execute("PRAGMA wal_checkpoint(PASSIVE)")
                self.error = None
            except sqlite3.Error as exc:
                self.error = f"checkpoint failed: {exc}"
