"""The PostgreSQL schema and its migrations: step for step those of the SQLite file
(:data:`elab.store._db.MIGRATIONS`, the same version numbers; a test compares the two
schemas' tables and columns after every step), in PostgreSQL's types: ``DOUBLE PRECISION``
for SQLite's ``REAL``, ``BIGINT`` for ``INTEGER``, ``BYTEA`` stored uncompressed for
``BLOB`` (a chunk's rows are read in place), and an identity column ``rowid`` where SQLite's
implicit one orders rows by arrival.

Migrating takes a transaction-scoped advisory lock first, so web nodes starting at once,
or ``elab migrate`` beside them, run each step once: the others wait, then find the
database current. The version is the one row of ``elab_schema``."""

from __future__ import annotations

from typing import Any

from elab.errors import ElabError
from elab.store._db import SCHEMA_VERSION

#: the advisory lock migrations hold (any fixed number; "elab" in ASCII)
MIGRATION_LOCK = 0x656C6162

_ROWID = "rowid BIGINT GENERATED ALWAYS AS IDENTITY UNIQUE"

#: ``MIGRATIONS[i]`` takes a database from version ``i`` to ``i + 1`` (as in SQLite).
MIGRATIONS: tuple[tuple[str, ...], ...] = (
    (  # 1: runs, their parameter changes and their samples
        f"""CREATE TABLE runs (
            id TEXT PRIMARY KEY, plant TEXT NOT NULL, mode TEXT NOT NULL,
            experiment TEXT NOT NULL, spec TEXT NOT NULL, status TEXT NOT NULL,
            Ts DOUBLE PRECISION NOT NULL, channels TEXT NOT NULL, n_planned BIGINT NOT NULL,
            n_stored BIGINT NOT NULL, created_at DOUBLE PRECISION NOT NULL,
            started_at DOUBLE PRECISION, finished_at DOUBLE PRECISION, error TEXT, {_ROWID})""",
        "CREATE INDEX runs_by_created ON runs (created_at)",
        "CREATE INDEX runs_by_plant ON runs (plant, created_at)",
        f"""CREATE TABLE param_changes (
            run_id TEXT NOT NULL REFERENCES runs (id), k BIGINT NOT NULL,
            at DOUBLE PRECISION NOT NULL, params TEXT NOT NULL, {_ROWID})""",
        "CREATE INDEX param_changes_by_run ON param_changes (run_id, k)",
        f"""CREATE TABLE chunks (
            run_id TEXT NOT NULL REFERENCES runs (id), k0 BIGINT NOT NULL,
            n BIGINT NOT NULL, data BYTEA NOT NULL, {_ROWID}, PRIMARY KEY (run_id, k0))""",
        # float64 bytes do not compress; uncompressed, substring() reads only its part
        "ALTER TABLE chunks ALTER COLUMN data SET STORAGE EXTERNAL",
    ),
    (  # 2: the engine that steps a run, and a row to write when checking that writing works
        "ALTER TABLE runs ADD COLUMN engine TEXT",
        "CREATE INDEX runs_by_engine ON runs (engine, status)",
        """CREATE TABLE probe (
            id INTEGER PRIMARY KEY CHECK (id = 1), at DOUBLE PRECISION NOT NULL)""",
    ),
    (  # 3: owners and private runs; API tokens (only their hashes); pinned runs
        "ALTER TABLE runs ADD COLUMN owner TEXT",
        "ALTER TABLE runs ADD COLUMN private INTEGER NOT NULL DEFAULT 0",
        "CREATE INDEX runs_by_owner ON runs (owner, created_at)",
        "CREATE INDEX runs_by_finished ON runs (finished_at)",
        """CREATE TABLE tokens (
            id TEXT PRIMARY KEY, hash TEXT NOT NULL UNIQUE, owner TEXT NOT NULL,
            name TEXT NOT NULL, created_at DOUBLE PRECISION NOT NULL,
            last_used DOUBLE PRECISION)""",
        "CREATE INDEX tokens_by_owner ON tokens (owner, created_at)",
        """CREATE TABLE pins (
            name TEXT PRIMARY KEY, run_id TEXT NOT NULL REFERENCES runs (id),
            owner TEXT NOT NULL, at DOUBLE PRECISION NOT NULL)""",
    ),
    (  # 4: controllers users upload
        f"""CREATE TABLE controllers (
            id TEXT PRIMARY KEY, owner TEXT NOT NULL, plant TEXT NOT NULL,
            name TEXT NOT NULL, format TEXT NOT NULL, law TEXT NOT NULL,
            report TEXT NOT NULL, source BYTEA NOT NULL,
            created_at DOUBLE PRECISION NOT NULL, {_ROWID})""",
        "CREATE INDEX controllers_by_owner ON controllers (owner, created_at)",
    ),
    (  # 5: a code controller's compute time per step (JSON)
        "ALTER TABLE runs ADD COLUMN compute TEXT",
    ),
    (  # 6: identified models users keep for design
        f"""CREATE TABLE models (
            id TEXT PRIMARY KEY, owner TEXT NOT NULL, plant TEXT NOT NULL,
            name TEXT NOT NULL, model TEXT NOT NULL, created_at DOUBLE PRECISION NOT NULL,
            {_ROWID})""",
        "CREATE INDEX models_by_owner ON models (owner, created_at)",
    ),
    (  # 7: instructors' sessions ended by signing out
        "CREATE TABLE ended_sessions (sid TEXT PRIMARY KEY, until DOUBLE PRECISION NOT NULL)",
    ),
    (  # 8: the rig queue: one seat row per rig, always the user at place 1
        """CREATE TABLE rigs (
            rig TEXT PRIMARY KEY, settling INTEGER NOT NULL CHECK (settling IN (0, 1)),
            out_of_service TEXT NOT NULL, updated_at DOUBLE PRECISION NOT NULL)""",
        """CREATE TABLE rig_queue (
            rig TEXT NOT NULL REFERENCES rigs (rig), place INTEGER NOT NULL CHECK (place >= 1),
            user_id TEXT NOT NULL, PRIMARY KEY (rig, place), UNIQUE (rig, user_id),
            UNIQUE (rig, place, user_id))""",
        """CREATE TABLE rig_seat (
            rig TEXT PRIMARY KEY REFERENCES rigs (rig),
            place INTEGER NOT NULL DEFAULT 1 CHECK (place = 1), user_id TEXT NOT NULL,
            phase TEXT NOT NULL CHECK (phase IN ('seated', 'armed', 'running')),
            since DOUBLE PRECISION NOT NULL, until DOUBLE PRECISION NOT NULL, run_id TEXT,
            took_over INTEGER NOT NULL CHECK (took_over IN (0, 1)),
            CHECK ((phase = 'running') = (run_id IS NOT NULL)),
            FOREIGN KEY (rig, place, user_id) REFERENCES rig_queue (rig, place, user_id)
                DEFERRABLE INITIALLY DEFERRED)""",
    ),
    (  # 9: how a run went beyond its state: its marks as JSON
        "ALTER TABLE runs ADD COLUMN outcome TEXT",
    ),
)
assert len(MIGRATIONS) == SCHEMA_VERSION, "a step of the SQLite schema is missing here"


def migrate(conn: Any, where: str) -> int:
    """Bring the database to :data:`SCHEMA_VERSION` in one transaction under
    :data:`MIGRATION_LOCK` (``conn``: a psycopg connection, not in a transaction); refuse a
    database written by a newer E-Lab. Returns the version found."""
    with conn.transaction():
        conn.execute("SELECT pg_advisory_xact_lock(%s)", (MIGRATION_LOCK,))
        conn.execute(
            "CREATE TABLE IF NOT EXISTS elab_schema ("
            "one INTEGER PRIMARY KEY DEFAULT 1 CHECK (one = 1), version INTEGER NOT NULL)"
        )
        found = version(conn, where)
        for step in MIGRATIONS[found:]:
            for statement in step:
                conn.execute(statement)
        conn.execute(
            "INSERT INTO elab_schema (one, version) VALUES (1, %s) "
            "ON CONFLICT (one) DO UPDATE SET version = excluded.version",
            (SCHEMA_VERSION,),
        )
    return found


def check_version(conn: Any, where: str) -> None:
    """Refuse a database not at :data:`SCHEMA_VERSION` (engines do not migrate)."""
    with conn.transaction():
        exists = conn.execute("SELECT to_regclass('elab_schema') IS NOT NULL").fetchone()[0]
        found = version(conn, where) if exists else 0
    if found != SCHEMA_VERSION:
        raise ElabError(
            f"{where}: store schema version {found}; this process expects {SCHEMA_VERSION} "
            "(run `elab migrate`, or start a web node, which migrates it, first)"
        )


def version(conn: Any, where: str) -> int:
    row = conn.execute("SELECT version FROM elab_schema").fetchone()
    found = 0 if row is None else int(row[0])
    if found > SCHEMA_VERSION:
        raise ElabError(
            f"{where}: store schema version {found} was written by a newer E-Lab; this "
            f"E-Lab reads versions up to {SCHEMA_VERSION}"
        )
    return found
