"""axe-core (Deque's accessibility engine, frontend/node_modules/axe-core) on every view of
the app, idle and during a live run (issue 27, item 7): no critical or serious violation
of WCAG 2.1 A/AA. Moderate and minor findings are listed in the failure message of a
serious one but do not fail the test."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Page, expect

from tests.api.server import Server, until

AXE = Path(__file__).resolve().parents[2] / "frontend" / "node_modules" / "axe-core" / "axe.min.js"
RUN_AXE = """async () => {
  const r = await axe.run(document, { runOnly: { type: 'tag',
    values: ['wcag2a', 'wcag2aa', 'wcag21a', 'wcag21aa'] } });
  return { passes: r.passes.length, violations: r.violations.map(v => ({ id: v.id,
    impact: v.impact, help: v.help, nodes: v.nodes.slice(0, 3).map(n => n.target.join(' ')) })) };
}"""
SAMPLES = "() => Number(document.querySelector('.progress')?.dataset.samples ?? 0)"
PLANTS = ("flexible_link", "double_pendulum", "belt_conveyor")


def violations(page: Page) -> list[dict[str, Any]]:
    """The page's critical and serious violations (axe injected once per page load)."""
    if not page.evaluate("() => typeof axe !== 'undefined'"):
        # evaluated, not added as a script tag: the app's Content-Security-Policy
        # (script-src 'self') refuses inline scripts, rightly
        page.evaluate(AXE.read_text(encoding="utf-8") + "\n;0")
    found: dict[str, Any] = page.evaluate(RUN_AXE)
    assert found["passes"] > 10, found  # the rules ran on the page's content
    return [v for v in found["violations"] if v["impact"] in ("critical", "serious")]


def settled(page: Page, path: str) -> None:
    """Open a view and wait until its heading and its data are drawn."""
    page.goto(path)
    expect(page.locator("header.page h1, h1").first).to_be_visible()
    page.wait_for_load_state("networkidle")


@pytest.fixture(scope="module")
def runs(shared_server: Server) -> Iterator[list[str]]:
    """Two finished runs of the flexible link (for /runs/:id and /compare)."""
    with shared_server.client() as c:
        ids = [
            c.post("/runs", json={"plant": "flexible_link", "duration": 2, "pace": "fast"}).json()[
                "id"
            ]
            for _ in range(2)
        ]
        for rid in ids:
            until(lambda rid=rid: c.get(f"/runs/{rid}").json()["finished_at"], 60)
    yield ids


def test_every_view_idle_has_no_serious_violation(page: Page, runs: list[str]) -> None:
    assert AXE.exists(), "axe-core is a dev dependency of the app: make install installs it"
    paths = ["/", "/runs", "/account", "/help", "/help/glossary", "/no/such/page"]
    for plant in PLANTS:
        paths += [f"/plants/{plant}", *(f"/plants/{plant}/{e}" for e in EXPERIMENTS)]
    paths += [f"/runs/{runs[0]}", f"/compare?runs={runs[0]},{runs[1]}"]
    found = {}
    for path in paths:
        settled(page, path)
        if bad := violations(page):
            found[path] = bad
    assert not found, found


EXPERIMENTS = ("analysis", "identification", "design")


def test_a_live_run_and_its_watcher_have_no_serious_violation(page: Page, server: Server) -> None:
    settled(page, "/plants/flexible_link/analysis")
    page.locator("#f-duration").fill("300")  # live through every check, on a slow machine too
    page.get_by_role("button", name="Start").click()
    page.wait_for_function(f"() => ({SAMPLES})() > 500")
    found = {"analysis, live": violations(page)}
    rid = page.get_attribute(".run-panel", "data-run")
    browser = page.context.browser
    assert rid and browser
    watcher = browser.new_page(base_url=server.url)
    try:
        watcher.goto(f"/runs/{rid}")
        watcher.wait_for_function(f"() => ({SAMPLES})() > 100")
        found["run page, live"] = violations(watcher)
        watcher.get_by_test_id("show-prediction").check()  # the model beside the run
        expect(watcher.get_by_test_id("prediction-diff").locator(".main-svg").first).to_be_visible()
        found["run page, live, with its prediction"] = violations(watcher)
        watcher.get_by_test_id("present").click()
        found["run page, live, presented"] = violations(watcher)
    finally:
        watcher.close()
    stop = page.get_by_role("button", name="Stop")
    if stop.is_enabled():  # (a 30 s run had ended before the checks beside the suite)
        stop.click()
    found = {k: v for k, v in found.items() if v}
    assert not found, found
