"""Schemathesis against a real `elab serve`: every operation of /api/v1/openapi.json with
every check (server errors, status codes, response schemas, schema-valid requests
accepted, schema-invalid ones rejected, `Allow` on 405, the stateful phase following the
links from POST /runs), bounded and with a fixed seed so a failure reproduces. The
per-operation exceptions (422 where validity depends on data the schema cannot state,
403 where only an instructor may) and why are in tests/api/fuzz/schemathesis.toml.

Three passes: without credentials (every request a new anonymous visitor; every phase,
the deterministic coverage phase included), with an API token (one identity throughout:
its own runs and tokens), and as a stranger aimed at another identity's runs (every
``run_id`` set to them). Afterwards those runs are as their owner left them: no operation
changed someone else's run."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from tests.api.server import Server, until

HERE = Path(__file__).parent / "fuzz"
ST = str(Path(sys.executable).parent / "st")


#: a SystemError from CPython 3.11's ast.parse (its recursion-depth accounting; see
#: CPython gh-106905) that Hypothesis can hit while describing one of its own strategies:
#: the tool failing, not the API (seen once in four full runs, in a pass whose 725 cases
#: had all passed)
TOOL_BUG = "AST constructor recursion depth mismatch"
SEED = 20261123


def schemathesis(srv: Server, *args: str, env: dict[str, str] | None = None) -> int:
    """One Schemathesis pass; the number of cases it ran (all of which passed). A pass that
    failed only by :data:`TOOL_BUG` runs again with the next seed, three times in all: under
    one seed the crash can repeat (three passes in a row once, stop 49); a finding names the
    seed that reproduces it."""
    for attempt in range(3):
        r = _run(srv, *args, env=env, seed=SEED + attempt)
        if not (r.returncode != 0 and TOOL_BUG in r.stdout and "Runtime Error: 1" in r.stdout):
            break
    assert r.returncode == 0, r.stdout[-6000:]
    ran = re.search(r"(\d+) generated, \1 passed", r.stdout)  # cases ran, and all passed
    assert ran, r.stdout[-3000:]
    return int(ran.group(1))


def _run(
    srv: Server, *args: str, env: dict[str, str] | None, seed: int
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            ST,
            *(["--config-file", str(HERE / "victim.toml")] if env else []),
            "run",
            srv.url + "/api/v1/openapi.json",
            "--checks",
            "all",
            "--seed",
            str(seed),
            "--workers",
            "2",
            *args,
        ],
        cwd=HERE,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        env={**os.environ, **(env or {})},
    )


def test_the_api_matches_its_openapi_document_under_fuzzing(tmp_path: Path) -> None:
    srv = Server(
        tmp_path / "data",
        ELAB_MAX_DURATION="3",
        ELAB_MAX_LIVE_RUNS="60",
        ELAB_MAX_LIVE_PER_IDENTITY="60",
        ELAB_OWNER_GRACE="3600",
        ELAB_OWNER_GONE="7200",
    ).start()
    try:
        with srv.client() as owner, srv.stranger() as fuzzer:
            paused = owner.post("/runs", json={"plant": "flexible_link", "duration": 3}).json()
            owner.post(f"/runs/{paused['id']}/pause")  # live while the fuzzer works
            ended = owner.post(
                "/runs", json={"plant": "belt_conveyor", "duration": 1, "pace": "fast"}
            ).json()
            until(lambda: owner.get(f"/runs/{ended['id']}").json()["finished_at"], 30)
            before = {r: owner.get(f"/runs/{r}").json() for r in (paused["id"], ended["id"])}
            token = fuzzer.post("/tokens", json={"name": "schemathesis"}).json()["token"]

            # without credentials each request is a new visitor: a token one of them made
            # is not the next one's to revoke, so "created resource not found" is expected
            n = schemathesis(
                srv, "--max-examples", "15", "--exclude-checks", "ensure_resource_availability"
            )
            # with a token: one identity through the stateful links; the coverage phase's
            # deterministic cases (each field's boundaries, types and omissions, 40 s of
            # Schemathesis's own CPU per pass) were the first pass's again
            n += schemathesis(
                srv,
                "--max-examples",
                "15",
                "--phases",
                "fuzzing,stateful",
                "-H",
                f"Authorization: Bearer {token}",
            )
            for victim in before:
                n += schemathesis(
                    srv,
                    "--max-examples",
                    "10",
                    "--include-path-regex",
                    "run_id",
                    "-H",
                    f"Authorization: Bearer {token}",
                    env={"ELAB_VICTIM_RUN": victim},
                )
            assert n > 6000, n
            for rid, was in before.items():  # as their owner left them
                now = owner.get(f"/runs/{rid}").json()
                assert now["status"] == was["status"] and now["param_changes"] == [], now
                assert now["error"] == was["error"] and now["finished_at"] == was["finished_at"]
            assert owner.get("/health").status_code == 200  # and the server is fine
    finally:
        srv.stop()
    assert "Traceback" not in srv.log, srv.log[-6000:]
