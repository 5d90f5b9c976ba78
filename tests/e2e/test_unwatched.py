"""The owner of a run closes the tab: after the grace period the run pauses, then stops,
with the reason in its record and its CSV header (a server with short periods; the
spectator's page, open all along, does not keep the run going and shows why)."""

from __future__ import annotations

from collections.abc import Iterator

import httpx
import pytest
from playwright.sync_api import Browser, expect

from tests.api.server import TLS, Server, until
from tests.e2e.test_access_ui import person, start_analysis


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    srv = Server(tmp_path_factory.mktemp("data"), ELAB_OWNER_GRACE="2", ELAB_OWNER_GONE="5").start()
    yield srv
    srv.stop()


def test_a_run_whose_owner_closed_the_tab_pauses_then_stops_with_the_reason(
    browser: Browser, server: Server
) -> None:
    api = server.url + "/api/v1/runs/"
    with person(browser, server) as spectator:
        with person(browser, server) as owner:
            rid = start_analysis(owner, duration="120")
            spectator.goto(f"/runs/{rid}")
            expect(spectator.locator(".run-panel .badge").first).to_have_text("running")
        # the owner's context (its tab) is closed here
        expect(spectator.locator(".run-panel .badge").first).to_have_text("paused", timeout=20_000)
        expect(spectator.locator(".run-panel")).to_contain_text("its owner has had no connection")
        expect(spectator.locator(".run-panel .badge").first).to_have_text("stopped", timeout=20_000)
        expect(spectator.locator(".run-panel")).to_contain_text("had no connection to it for 5 s")
    run = until(lambda: (r := httpx.get(api + rid, verify=TLS).json())["finished_at"] and r, 20)
    assert run["status"] == "stopped"
    assert run["error"].startswith("stopped: its owner had no connection to it for 5 s")
    head = httpx.get(api + rid + "/data").text.split("\nt,", 1)[0]
    assert "# reason: stopped: its owner had no connection to it for 5 s" in head
