"""``store``: an empty store of each kind, the embedded SQLite file and PostgreSQL (a fresh
schema of the worker's server), so every test of the protocols runs on both."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from elab.store import Store, open_store
from tests.postgres import PostgresServer

KINDS = ["sqlite", "postgres"]


def fresh_target(kind: str, tmp_path: Path, request: pytest.FixtureRequest) -> str:
    """Where an empty store of ``kind`` is: a file's path, or a URL."""
    if kind == "sqlite":
        return str(tmp_path / "db" / "runs.sqlite")
    pg: PostgresServer = request.getfixturevalue("postgres")
    return pg.schema()


def fresh_store(kind: str, tmp_path: Path, request: pytest.FixtureRequest) -> Store:
    return open_store(fresh_target(kind, tmp_path, request))


@pytest.fixture(params=KINDS)
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Store]:
    s = fresh_store(request.param, tmp_path, request)
    try:
        yield s
    finally:
        s.close()


@pytest.fixture(params=KINDS)
def target(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """Where a store of each kind, migrated and empty, is (for several processes to open)."""
    where = fresh_target(request.param, tmp_path, request)
    open_store(where).close()
    return where
