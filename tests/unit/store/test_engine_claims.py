"""An engine's name is held in its store while its process lives: a second server on the
same file or database cannot start an engine of the same name (it would mark the first's
live runs interrupted), and a process that dies, even by ``kill -9``, lets go at once.
On both back-ends (the ``target`` fixture)."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from elab.errors import ElabError
from elab.store import SQLiteStore, open_store
from tests.postgres import PostgresServer

HOLDER = """
import sys, time
from elab.store import SQLiteStore, open_store
from tests.postgres import PostgresServer
store = open_store(sys.argv[1], migrate=False)
store.claim("sim-0")
print("claimed", flush=True)
time.sleep(600)
"""


def test_a_second_claim_of_an_engine_waits_then_fails_by_name(target: str) -> None:
    first, second = open_store(target), open_store(target)
    try:
        first.claim("sim-0")
        second.claim("rig-0", wait=0.0)  # another engine's name is free
        t0 = time.monotonic()
        with pytest.raises(ElabError, match=r"'sim-0' is already running on this store"):
            second.claim("sim-0", wait=0.5)
        assert time.monotonic() - t0 >= 0.5  # it waited for a restarting engine
        first.close()
        second.claim("sim-0", wait=5.0)  # closed: free
    finally:
        for s in (first, second):
            s.close()


def test_a_name_the_store_holds_is_held_again_at_once(target: str) -> None:
    with open_store(target) as store, open_store(target) as other:
        store.claim("web", wait=0.0)
        store.claim("web", wait=0.0)  # the same store: held, not a second claimant
        with pytest.raises(ElabError, match="'web' is already running"):
            other.claim("web", wait=0.0)


def test_a_file_in_use_is_refused_before_it_is_upgraded(tmp_path: Path) -> None:
    """``claim=`` holds the name before the file is migrated: a server of an older version
    using the file never sees its schema change under it."""
    path = tmp_path / "elab.sqlite3"
    with SQLiteStore(path) as serving:
        serving.claim("web")
        with sqlite3.connect(path) as db:  # as an older version would have left it
            db.execute("PRAGMA user_version = 8")
        with pytest.raises(ElabError, match="'web' is already running"):
            SQLiteStore(path, claim="web")
        with sqlite3.connect(path) as db:
            assert db.execute("PRAGMA user_version").fetchone()[0] == 8  # untouched


def test_a_killed_holder_lets_go_of_its_engine(target: str) -> None:
    with subprocess.Popen(
        [sys.executable, "-c", HOLDER, target], stdout=subprocess.PIPE, text=True
    ) as holder:
        try:
            assert holder.stdout is not None and holder.stdout.readline().strip() == "claimed"
            with open_store(target) as store:
                with pytest.raises(ElabError):
                    store.claim("sim-0", wait=0.2)
                os.kill(holder.pid, signal.SIGKILL)
                holder.wait(30)
                store.claim("sim-0", wait=30.0)  # at once, within a generous cap
        finally:
            holder.kill()


def test_stores_in_two_schemas_of_one_database_claim_apart(postgres: PostgresServer) -> None:
    """A store is its tables in the connection's schema: two schemas of one database (as
    the tests give each server) are two stores, though advisory locks are the database's."""
    with open_store(postgres.schema()) as a, open_store(postgres.schema()) as b:
        a.claim("web")
        b.claim("web", wait=0.0)
