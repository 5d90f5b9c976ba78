"""Who may do what, in the browser: a run's owner and its spectators, an instructor who
signs in, pauses a student's run and pins it as the class demo, Start and the page's
previous run, My runs, API tokens. Each browser context is one person (its own
anonymous identity cookie)."""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx
import pytest
from playwright.sync_api import Browser, Page, expect

from elab.api.auth import hash_password
from tests.api.server import Server, until

PASSWORD = "correct horse"
GUEST = re.compile(r"guest [0-9a-f]{4}")
SAMPLES = "Number(document.querySelector('.progress')?.dataset.samples ?? 0)"


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    accounts = tmp_path_factory.mktemp("accounts") / "instructors"
    accounts.write_text(f"prof:{hash_password(PASSWORD)}\n")
    srv = Server(tmp_path_factory.mktemp("data"), ELAB_INSTRUCTORS=str(accounts)).start()
    yield srv
    srv.stop()


@contextmanager
def person(browser: Browser, server: Server) -> Iterator[Page]:
    """A browser context of its own: another person, with another anonymous identity."""
    context = browser.new_context(viewport={"width": 1280, "height": 800}, base_url=server.url)
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        yield page
    finally:
        context.close()
    assert not errors, f"errors in the page: {errors}"


def me(page: Page) -> dict[str, Any]:
    """Who the server takes this page's browser for."""
    return page.evaluate("async () => (await fetch('/api/v1/me')).json()")  # type: ignore[no-any-return]


def run(server: Server, rid: str) -> dict[str, Any]:
    """A public run as anyone sees it."""
    r = httpx.get(f"{server.url}/api/v1/runs/{rid}", timeout=30)
    r.raise_for_status()
    return r.json()  # type: ignore[no-any-return]


def shown_run(page: Page, other_than: str | None = None) -> str:
    """The run the page's run panel shows (once it is another than ``other_than``)."""
    panel = page.locator(".run-panel")
    if other_than is None:
        expect(panel).to_have_count(1)
    else:
        expect(panel).not_to_have_attribute("data-run", other_than)
    return str(panel.get_attribute("data-run"))


def start_analysis(page: Page, duration: str = "60") -> str:
    """Start a closed-loop run on the flexible link's analysis page; its id once live."""
    page.goto("/plants/flexible_link/analysis")
    page.locator("#f-duration").fill(duration)
    page.get_by_role("button", name="Start").click()
    rid = shown_run(page)
    expect(page.locator(".run-panel .badge").first).to_have_text("running")
    return rid


def start_again(page: Page, previous: str) -> str:
    page.get_by_role("button", name="Start a new run").click()
    rid = shown_run(page, other_than=previous)
    expect(page.locator(".run-panel .badge").first).to_have_text("running")
    return rid


def test_a_spectator_sees_who_controls_a_run_and_may_not_stop_it(
    browser: Browser, server: Server, shots: Path
) -> None:
    with person(browser, server) as a, person(browser, server) as b:
        rid = start_analysis(a)
        owner = me(a)["name"]
        assert GUEST.fullmatch(owner)
        expect(a.get_by_test_id("who")).to_have_text(f"You: {owner}")
        expect(a.get_by_test_id("run-owner")).to_have_text("Your run")
        expect(a.locator(".run-panel").get_by_role("button", name="Stop")).to_be_visible()

        b.goto(f"/runs/{rid}")
        expect(b.get_by_test_id("run-owner")).to_have_text(f"Controlled by {owner}")
        expect(b.get_by_test_id("who")).to_have_text(f"You: {me(b)['name']}")
        assert me(b)["id"] != me(a)["id"]
        b.wait_for_function(f"() => {SAMPLES} > 0")
        panel = b.locator(".run-panel")
        for name in ("Pause", "Resume", "Stop"):
            expect(panel.get_by_role("button", name=name, exact=True)).to_have_count(0)
        b.screenshot(path=shots / "run-spectator.png", full_page=True)

        # the API refuses B too, and the run goes on
        answer = b.evaluate(
            """async (id) => { const r = await fetch(`/api/v1/runs/${id}/stop`, {method: "POST"});
                return {status: r.status, body: await r.json()}; }""",
            rid,
        )
        assert answer["status"] == 403
        assert answer["body"]["error"]["code"] == "forbidden"
        n = run(server, rid)["n_samples"]
        until(lambda: run(server, rid)["n_samples"] > n + 200, timeout=20)
        assert run(server, rid)["status"] == "running"

        # its owner stops it; the spectator reads why, as a notice
        a.locator(".run-panel").get_by_role("button", name="Stop").click()
        expect(b.locator(".run-panel .badge").first).to_have_text("stopped")
        expect(b.get_by_test_id("run-notice")).to_have_text("stopped by its owner")
        expect(b.locator(".run-panel .error")).to_be_empty()


def test_an_instructor_pauses_a_students_run_and_pins_it_as_the_class_demo(
    browser: Browser, server: Server, shots: Path
) -> None:
    with (
        person(browser, server) as a,
        person(browser, server) as b,
        person(browser, server) as prof,
    ):
        rid = start_analysis(a)
        owner = me(a)["name"]

        prof.goto("/account")
        prof.get_by_label("Name").fill("prof")
        prof.get_by_label("Password").fill("not the password")
        prof.get_by_role("button", name="Sign in").click()
        expect(prof.get_by_test_id("sign-in-error")).to_have_text(
            "unknown instructor or wrong password"
        )
        prof.get_by_label("Password").fill(PASSWORD)
        prof.get_by_role("button", name="Sign in").click()
        expect(prof.get_by_test_id("who")).to_have_text("prof · instructor")
        expect(prof.get_by_test_id("identity")).to_contain_text("signed in as an instructor")
        expect(prof.get_by_role("button", name="Sign out")).to_be_visible()
        assert me(prof) == {
            "id": "i-prof",
            "name": "prof (instructor)",
            "role": "instructor",
            "via": "session",
            "account": "prof",
            "sign_in": True,
        }
        prof.screenshot(path=shots / "account-instructor.png", full_page=True)

        prof.get_by_role("link", name="Runs", exact=True).click()
        prof.locator(f"tr[data-run={rid}]").get_by_role("link").click()
        expect(prof.get_by_test_id("run-owner")).to_have_text(f"Controlled by {owner}")
        prof.locator(".run-panel").get_by_role("button", name="Pause").click()
        expect(prof.locator(".run-panel .badge").first).to_have_text("paused")
        assert run(server, rid)["status"] == "paused"
        # the owner reads who paused it, as a notice and not an error
        expect(a.locator(".run-panel .badge").first).to_have_text("paused")
        expect(a.get_by_test_id("run-notice")).to_have_text("paused by prof (instructor)")
        expect(a.locator(".run-panel .error")).to_be_empty()
        a.screenshot(path=shots / "analysis-paused-by-instructor.png", full_page=True)

        prof.get_by_role("button", name="Pin as class demo").click()
        expect(prof.get_by_test_id("pinned")).to_be_visible()

        b.goto("/")
        banner = b.get_by_test_id("demo-banner")
        expect(banner).to_be_visible()
        expect(banner).to_have_attribute("data-run", rid)
        expect(banner.locator(".badge")).to_have_text("paused")
        expect(banner.get_by_role("button", name="Unpin")).to_have_count(0)
        b.screenshot(path=shots / "home-class-demo.png", full_page=True)
        banner.get_by_role("link").click()
        expect(b).to_have_url(re.compile(f"/runs/{rid}$"))

        # the instructor unpins it from the start page, and signs out
        prof.goto("/")
        prof.get_by_test_id("demo-banner").get_by_role("button", name="Unpin").click()
        expect(prof.get_by_test_id("demo-banner")).to_have_count(0)
        b.goto("/")
        expect(b.locator("#plants-h")).to_be_visible()
        expect(b.get_by_test_id("demo-banner")).to_have_count(0)
        prof.get_by_test_id("who").click()
        prof.get_by_role("button", name="Sign out").click()
        expect(prof.get_by_test_id("who")).to_have_text(GUEST)
        assert me(prof)["role"] == "student"


def test_start_stops_the_pages_previous_run_unless_it_is_kept_going(
    browser: Browser, server: Server
) -> None:
    with person(browser, server) as a, person(browser, server) as b:
        first = start_analysis(a)
        second = start_again(a, first)
        until(lambda: run(server, first)["status"] == "stopped", timeout=20)
        assert run(server, first)["error"] == "stopped by its owner"
        assert run(server, second)["status"] == "running"

        a.get_by_label("Keep my previous run going").check()
        a.get_by_label("Private run").check()
        third = start_again(a, second)
        expect(a.locator(".run-panel .badge.private")).to_have_text("private")
        a.wait_for_function(f"() => {SAMPLES} > 1000")
        assert run(server, second)["status"] == "running"  # kept going
        mine = a.request.get(f"/api/v1/runs/{third}").json()
        assert mine["private"] is True and mine["mine"] is True
        assert httpx.get(f"{server.url}/api/v1/runs/{third}").status_code == 404  # others: none
        b.goto(f"/runs/{third}")
        expect(b.locator(".failure")).to_contain_text("unknown run")
        for rid in (second, third):
            assert a.request.post(f"/api/v1/runs/{rid}/stop").ok


def test_my_runs_lists_only_mine_and_a_run_can_be_stopped_and_deleted_there(
    browser: Browser, server: Server, shots: Path
) -> None:
    with person(browser, server) as a, person(browser, server) as b:
        a.goto("/runs")  # the first visit gives the browser its identity
        b.goto("/runs")
        fast = {"plant": "belt_conveyor", "duration": 0.5, "pace": "fast"}
        mine = [a.request.post("/api/v1/runs", data=fast).json()["id"] for _ in range(2)]
        theirs = b.request.post("/api/v1/runs", data=fast).json()["id"]
        live = a.request.post(
            "/api/v1/runs", data={"plant": "belt_conveyor", "duration": 60}
        ).json()["id"]
        for rid in (*mine, theirs):
            until(lambda rid=rid: run(server, rid)["status"] == "finished", timeout=20)

        a.get_by_label("My runs").check()
        expect(a).to_have_url(re.compile(r"/runs\?owner=me$"))
        rows = a.locator("table.runs tbody tr")
        expect(rows).to_have_count(3)
        assert {r.get_attribute("data-run") for r in rows.all()} == {*mine, live}
        for row in rows.all():
            expect(row.locator("td.owner")).to_have_text("you")
        a.screenshot(path=shots / "runs-mine.png", full_page=True)
        a.reload()  # the filter is kept in the address
        expect(a.get_by_label("My runs")).to_be_checked()
        expect(rows).to_have_count(3)

        # Delete (ended runs), after confirming
        row = a.locator(f"tr[data-run={mine[0]}]")
        expect(row.get_by_role("button", name="Stop")).to_have_count(0)
        a.once("dialog", lambda d: d.accept())
        row.get_by_role("button", name="Delete").click()
        expect(row).to_have_count(0)
        expect(rows).to_have_count(2)
        assert a.request.get(f"/api/v1/runs/{mine[0]}").status == 404

        # Stop (live runs)
        a.get_by_label("Live now").check()
        expect(a).to_have_url(re.compile(r"/runs\?live=true$"))
        row = a.locator(f"tr[data-run={live}]")
        row.get_by_role("button", name="Stop").click()
        expect(row).to_have_count(0, timeout=10_000)  # no longer live (the list refreshes)
        assert run(server, live)["error"] == "stopped by its owner"

        # everybody's runs: B sees A's, with no buttons; its own with Delete
        b.get_by_label("All runs").check()
        expect(b).to_have_url(re.compile(r"/runs$"))
        other = b.locator(f"tr[data-run={mine[1]}]")
        expect(other.locator("td.owner")).to_have_text(me(a)["name"])
        expect(other.get_by_role("button")).to_have_count(0)
        own = b.locator(f"tr[data-run={theirs}]")
        expect(own.get_by_role("button", name="Delete")).to_be_visible()


def test_an_api_token_is_shown_once_and_acts_as_the_browser(
    browser: Browser, server: Server, shots: Path
) -> None:
    with person(browser, server) as a:
        a.goto("/account")
        who = me(a)
        expect(a.get_by_test_id("identity")).to_contain_text(who["name"])
        expect(a.get_by_role("button", name="Sign in")).to_be_visible()

        a.get_by_role("button", name="Create token").click()
        expect(a.get_by_test_id("token-error")).to_contain_text("Say what the token is for")
        a.get_by_label("What it is for").fill("grader")
        a.get_by_role("button", name="Create token").click()
        box = a.get_by_test_id("new-token")
        expect(box).to_contain_text("shown only this once")
        expect(box).to_contain_text("Authorization: Bearer <token>")
        token = a.get_by_test_id("token-value").input_value()
        assert token.startswith("elab_")
        expect(a.get_by_test_id("token-list")).to_contain_text("grader")
        a.screenshot(path=shots / "account-token.png", full_page=True)

        bearer = {"authorization": f"Bearer {token}"}
        got = httpx.get(f"{server.url}/api/v1/me", headers=bearer, timeout=30).json()
        assert got["id"] == who["id"]
        assert got["via"] == "token"

        a.reload()  # never shown again
        expect(a.get_by_test_id("token-list")).to_contain_text("grader")
        expect(a.get_by_test_id("new-token")).to_be_hidden()
        assert token not in a.content()
        expect(a.get_by_test_id("token-list").locator("td").nth(2)).not_to_have_text("never")

        a.once("dialog", lambda d: d.accept())
        a.get_by_test_id("token-list").get_by_role("button", name="Revoke").click()
        expect(a.get_by_test_id("token-list")).to_have_text("No tokens yet.")
        gone = httpx.get(f"{server.url}/api/v1/me", headers=bearer, timeout=30)
        assert gone.status_code == 401
