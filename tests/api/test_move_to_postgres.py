"""An embedded lab moved into PostgreSQL as docs/operations.md says: stop the server,
``elab migrate --from $ELAB_DATA/elab.sqlite3`` with ``ELAB_DATABASE_URL`` set, start it
again with the URL. The same visitor finds its runs (private ones too), the same bytes in
every download, its uploaded controller and its pin; new runs go on from there. Real
processes, a real PostgreSQL server on loopback."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from tests.api.server import ELAB, Server, until
from tests.api.test_live_runs import downloads
from tests.postgres import PostgresServer

RUN = {"plant": "flexible_link", "duration": 1.5, "pace": "fast", "noise": True, "seed": 3}


@pytest.mark.sqlite_only("the embedded lab's file is what moves")
def test_an_embedded_lab_moved_into_postgres_keeps_everything(
    tmp_path: Path, postgres: PostgresServer
) -> None:
    data = tmp_path / "data"
    old = Server(data).start()
    try:
        with old.client() as c:
            rids = [c.post("/runs", json=RUN | {"private": i == 1}).json()["id"] for i in range(2)]
            for rid in rids:
                until(lambda rid=rid: c.get(f"/runs/{rid}").json()["status"] == "finished")
            before = {rid: downloads(c, rid) for rid in rids}
            listed = c.get("/runs", params={"owner": "me"}).json()
            assert [r["id"] for r in listed["runs"]] == rids[::-1]
            assert [r["private"] for r in listed["runs"]] == [True, False]
    finally:
        old.stop()

    url = postgres.schema()
    moved = subprocess.run(
        [ELAB, "migrate", "--from", str(data / "elab.sqlite3")],
        env={**old.env, "ELAB_DATABASE_URL": url},
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    ).stdout
    assert "schema version 0 -> " in moved and "copied from" in moved and "2 runs" in moved

    new = Server(data, ELAB_DATABASE_URL=url)
    new.cookies = old.cookies  # the same browser (the same secret in ELAB_DATA signs it)
    new.start()
    try:
        with new.client() as c:
            assert c.get("/runs", params={"owner": "me"}).json() == listed
            for rid in rids:
                after = downloads(c, rid)
                assert after["csv_text"] == before[rid]["csv_text"]
                for fmt in ("json", "mat"):
                    np.testing.assert_array_equal(after[fmt], before[rid][fmt])
            rid = c.post("/runs", json=RUN).json()["id"]
            until(lambda: c.get(f"/runs/{rid}").json()["status"] == "finished")
            assert c.get("/runs", params={"owner": "me"}).json()["runs"][0]["id"] == rid
        # and the file is left as it was, for going back
        assert (data / "elab.sqlite3").stat().st_size > 0
    finally:
        new.stop()
