"""Schemathesis against a real `elab serve`: every operation of /api/v1/openapi.json with
every check (server errors, status codes, response schemas, schema-valid requests
accepted, schema-invalid ones rejected, `Allow` on 405, the stateful phase following the
links from POST /runs), bounded and with a fixed seed so a failure reproduces. The
per-operation exceptions (422 where validity depends on data the schema cannot state) and
why are in tests/api/fuzz/schemathesis.toml."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from tests.api.server import Server

HERE = Path(__file__).parent / "fuzz"
ST = str(Path(sys.executable).parent / "st")


def test_the_api_matches_its_openapi_document_under_fuzzing(tmp_path: Path) -> None:
    srv = Server(
        tmp_path / "data",
        ELAB_MAX_DURATION="3",
        ELAB_MAX_LIVE_RUNS="60",
        ELAB_MAX_LIVE_PER_IDENTITY="60",
    ).start()
    try:
        r = subprocess.run(
            [
                ST,
                "run",
                srv.url + "/api/v1/openapi.json",
                "--checks",
                "all",
                "--max-examples",
                "25",
                "--seed",
                "20261123",
                "--workers",
                "2",
            ],
            cwd=HERE,
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )
        assert r.returncode == 0, r.stdout[-6000:]
        ran = re.search(r"(\d+) generated, \1 passed", r.stdout)  # cases ran, and all passed
        assert ran and int(ran.group(1)) > 500, r.stdout[-3000:]
        with srv.client() as c:  # and the server is fine afterwards
            assert c.get("/health").status_code == 200
    finally:
        srv.stop()
    assert "Traceback" not in srv.log, srv.log[-6000:]
