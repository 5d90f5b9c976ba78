"""Fixtures of every test: live servers for the API and browser tests.

``server``: one ``elab serve`` per test worker (pytest-xdist), shared by every test that
needs no settings of its own; each test sees it as a new visitor (its own identity and its
own part of the log). Tests on one worker run one after another, so a test may also stop
or kill one of the shared server's processes for a while, provided it proves that the
server recovered before it ends (its engine restarted, its web process going on). A test
that needs other settings, stops or restarts the whole server, or breaks its data
directory starts a ``Server`` of its own."""

from __future__ import annotations

import os
import sys

# One BLAS thread per process, as `elab` runs (elab/__init__.py), set before numpy loads
# where it can be: OpenBLAS's own threads on a 2-core machine already running two test
# workers spin against each other (tests/unit/ident took 116 s with them, 47 s without).
# scripts/test.sh sets it for every process; this is for a bare `pytest`.
if "numpy" not in sys.modules:
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")

from collections.abc import Iterator

import pytest

from tests.api import server as servers
from tests.api.server import Server
from tests.postgres import PostgresServer
from tests.redis_server import RedisServer


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--store",
        choices=("sqlite", "postgres"),
        default=os.environ.get("ELAB_TEST_STORE", "sqlite"),
        help="where the test servers keep their records: the embedded SQLite file, or "
        "PostgreSQL (a server of each worker's own, a fresh database schema per test server; "
        "`make test-postgres`)",
    )
    parser.addoption(
        "--engines",
        choices=("local", "broker"),
        default=os.environ.get("ELAB_TEST_ENGINES", "local"),
        help="the test servers' simulation engines: the process each server starts, or "
        f"{servers.ENGINES} processes of their own on a Redis broker beside each server "
        "(`make test-cluster`)",
    )


@pytest.fixture(scope="session", autouse=True)
def _servers_store(request: pytest.FixtureRequest) -> None:
    """With ``--store postgres``, every test server (``Server``) gets a database of its own
    on this worker's PostgreSQL server (``ELAB_DATABASE_URL``)."""
    if request.config.getoption("--store") == "postgres":
        pg: PostgresServer = request.getfixturevalue("postgres")
        servers.DATABASES = pg.schema
    if request.config.getoption("--engines") == "broker":
        broker: RedisServer = request.getfixturevalue("redis_server")
        servers.BROKERS = broker.url


@pytest.fixture(scope="session")
def shared_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    srv = Server(tmp_path_factory.mktemp("shared") / "data").start()
    yield srv
    srv.stop()


@pytest.fixture
def server(shared_server: Server) -> Server:
    return shared_server.visitor()


#: the modules that take longest (about half the suite's time; measured with
#: ``PYTEST_ADDOPTS=--durations=0 make test``, docs/benchmarks.md), longest first. They are
#: collected first, so pytest-xdist (``--dist loadscope --no-loadscope-reorder`` in
#: scripts/test.sh: a module stays on one worker, modules go out in collection order) hands
#: them out first and the short modules fill in at the end. xdist's default order, by
#: number of tests, sent the one-test fuzz module (100 s) out last, and a core idled for a
#: minute. A module missing here only runs later; the order changes no result.
LONGEST_FIRST = (
    "tests/api/test_rig.py",
    "tests/api/test_fuzz.py",
    "tests/e2e/test_app.py",
    "tests/api/test_live_runs.py",
    # after test_rig.py has ended on the other worker: two emulated rigs at 1 kHz at once
    # on two cores starve each other's clocks
    "tests/e2e/test_rig_ui.py",
    "tests/api/test_durable.py",
    "tests/api/test_extreme_numbers.py",
    "tests/api/test_access.py",
    "tests/api/test_processes.py",
    "tests/api/test_sessions.py",
    "tests/api/test_storage_faults.py",
    "tests/api/test_limits.py",
    "tests/e2e/test_run_view.py",
    "tests/e2e/test_access_ui.py",
    "tests/unit/ident/test_pem_minima.py",
    "tests/api/test_code_controllers.py",
    "tests/e2e/test_controller_upload.py",
    "tests/e2e/test_design_on_models.py",
    "tests/api/test_rig_machine.py",
    # not beside the rig engine's tests: 20 pages of axe in Chromium there starved the
    # emulated rig's 1 kHz clock (its safety trip in 2 of 5 runs of this stop, unproven)
    "tests/e2e/test_accessibility.py",
    "tests/unit/engines/test_rig_engine.py",
)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    rank = {path: i for i, path in enumerate(LONGEST_FIRST)}
    # a stable sort: within a module, and among the others, the order stays as collected
    items.sort(key=lambda item: rank.get(item.nodeid.split("::", 1)[0], len(rank)))
    if config.getoption("--store") == "postgres":
        for item in items:
            if (mark := item.get_closest_marker("sqlite_only")) is not None:
                item.add_marker(pytest.mark.skip(reason=f"the SQLite file itself: {mark.args[0]}"))
    if config.getoption("--engines") == "broker":
        for item in items:
            if (mark := item.get_closest_marker("local_engine_only")) is not None:
                why = f"the engine the server starts itself: {mark.args[0]}"
                item.add_marker(pytest.mark.skip(reason=why))


@pytest.fixture(scope="session")
def redis_server() -> Iterator[RedisServer]:
    """A Redis server of this test worker's own (tests/redis_server.py)."""
    broker = RedisServer()
    broker.start()
    yield broker
    broker.stop()


@pytest.fixture(scope="session")
def postgres() -> Iterator[PostgresServer]:
    """A PostgreSQL server of this test worker's own (tests/postgres.py), started on first
    use."""
    pg = PostgresServer()
    pg.start()
    yield pg
    pg.stop()
