"""The PostgreSQL store beyond what both stores share (those tests run on both: the
``store`` fixture): its schema step for step the SQLite file's, migrations that several
processes may start at once, engines that refuse a database not migrated, faults as
StoreErrors, no password in what it says. A real server (tests/postgres.py)."""

from __future__ import annotations

import sqlite3
import threading
from pathlib import Path

import numpy as np
import psycopg
import pytest

from elab.errors import ElabError
from elab.store import RunRecord, StoreError, _db, open_store
from elab.store.postgres import schema
from elab.store.postgres.connections import redacted
from tests.postgres import PostgresServer


def _sqlite_columns(conn: sqlite3.Connection) -> dict[str, set[str]]:
    tables = [r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
    return {t: {r[1].lower() for r in conn.execute(f"PRAGMA table_info({t})")} for t in tables}


def _pg_columns(conn: psycopg.Connection) -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for table, column in conn.execute(
        "SELECT table_name, column_name FROM information_schema.columns "
        "WHERE table_schema = current_schema()"
    ):
        if column != "rowid":  # SQLite's is implicit
            out.setdefault(table, set()).add(column)
    out.pop("elab_schema", None)
    return out


def test_every_migration_step_gives_the_sqlite_files_tables_and_columns(
    postgres: PostgresServer, tmp_path: Path
) -> None:
    assert len(schema.MIGRATIONS) == len(_db.MIGRATIONS) == _db.SCHEMA_VERSION
    lite = sqlite3.connect(tmp_path / "steps.sqlite3")
    with psycopg.connect(postgres.schema(), autocommit=True) as pg:
        for version, (lite_step, pg_step) in enumerate(
            zip(_db.MIGRATIONS, schema.MIGRATIONS, strict=True), start=1
        ):
            for statement in lite_step:
                lite.execute(statement)
            for statement in pg_step:
                pg.execute(statement)
            assert _pg_columns(pg) == _sqlite_columns(lite), f"after step {version}"
    lite.close()


def test_web_nodes_migrating_at_once_run_each_step_once(postgres: PostgresServer) -> None:
    url = postgres.schema()
    barrier = threading.Barrier(6)
    found: list[int] = []
    errors: list[BaseException] = []

    def node() -> None:
        try:
            barrier.wait()
            with psycopg.connect(url, autocommit=True) as conn:
                found.append(schema.migrate(conn, "test"))
        except BaseException as e:  # reported below
            errors.append(e)

    threads = [threading.Thread(target=node) for _ in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    assert errors == [] and sorted(found) == [0] + [_db.SCHEMA_VERSION] * 5
    with open_store(url, migrate=False) as store:  # an engine finds it current
        store.probe()


def test_an_engine_refuses_a_database_not_migrated_or_newer(postgres: PostgresServer) -> None:
    url = postgres.schema()
    with pytest.raises(ElabError, match=r"schema version 0.*elab migrate"):
        open_store(url, migrate=False)
    open_store(url).close()
    with psycopg.connect(url, autocommit=True) as conn:
        conn.execute("UPDATE elab_schema SET version = version + 1")
    with pytest.raises(ElabError, match=r"written by a newer E-Lab"):
        open_store(url)


def test_a_database_nobody_answers_for_is_a_transient_store_error_without_password() -> None:
    from elab.store.postgres import PostgresStore

    with pytest.raises(StoreError) as e:
        PostgresStore("postgresql://elab:s3cret@127.0.0.1:9/elab", timeout=1.0)
    assert e.value.transient and "s3cret" not in str(e.value)
    assert redacted("postgresql://elab:s3cret@db.example:6543/lab") == (
        "postgresql://elab@db.example:6543/lab"
    )


def test_connections_killed_under_the_store_are_replaced(postgres: PostgresServer) -> None:
    """The database restarts or an administrator ends the sessions: an operation may fail,
    transiently, and the next ones work on new connections."""
    with open_store(postgres.schema()) as store:
        store.create_run(
            RunRecord(
                id="r-1", plant="flexible_link", mode="simulation", experiment="analysis",
                spec={}, status="running", Ts=1e-3, channels=(("u", "V"),), n_planned=10,
                created_at=1.7e9,
            )
        )  # fmt: skip
        with psycopg.connect(postgres.url, autocommit=True) as admin:
            admin.execute(
                "SELECT pg_terminate_backend(pid) FROM pg_stat_activity "
                "WHERE datname = 'elab' AND pid <> pg_backend_pid()"
            )
        failures = 0
        for _ in range(3):
            try:
                store.append("r-1", 0, np.ones((4, 1)))
                break
            except StoreError as e:
                assert e.transient, e
                failures += 1
        assert failures < 3
        assert store.read("r-1").shape == (4, 1)
