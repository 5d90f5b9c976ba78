"""Fixtures of every test: live servers for the API and browser tests.

``server``: one ``elab serve`` per test worker (pytest-xdist), shared by every test that
needs no settings of its own; each test sees it as a new visitor (its own identity and its
own part of the log). A test that needs other settings, or kills or stops the server,
starts a ``Server`` of its own."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.api.server import Server


@pytest.fixture(scope="session")
def shared_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    srv = Server(tmp_path_factory.mktemp("shared") / "data").start()
    yield srv
    srv.stop()


@pytest.fixture
def server(shared_server: Server) -> Server:
    return shared_server.visitor()
