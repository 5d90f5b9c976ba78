"""The rig in the browser, against a real server with an emulated rig (``ELAB_RIG=emulator``:
``elab rig-emulator`` in a process of its own): the start page says what the rig is and
that it is emulated; a student picks the real rig on the flexible link's analysis page,
joins the queue, arms, starts a run that streams, presses the emergency stop (with the
keyboard) and reads why the run stopped; another person sees the rig in use and their own
place in the queue; an instructor takes the rig over from the status panel. Each browser
context is one person."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser, Page, expect

from tests.api.server import Server, until
from tests.api.test_access import PASSWORD, instructor, instructors_file
from tests.e2e.test_access_ui import person

SAMPLES = "Number(document.querySelector('.run-panel .progress')?.dataset.samples ?? 0)"
GUEST = r"guest [0-9a-f]{4}"


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    # a lenient watchdog: beside two CPU hogs the rig engine can wait longer than 5 ms for
    # a CPU (as tests/api/test_rig.py)
    data = tmp_path_factory.mktemp("rig-ui")
    srv = Server(
        data,
        ELAB_RIG="emulator",
        ELAB_RIG_WATCHDOG="200",
        ELAB_INSTRUCTORS=str(instructors_file(data.parent)),
    )
    try:  # a server that did not start in time is stopped too, with its rig emulator
        srv.start()
        until(lambda: (srv.status().get("rig") or {}).get("connected"), 60)
        yield srv
    finally:
        srv.stop()


@pytest.fixture(autouse=True)
def free_rig(server: Server) -> Iterator[None]:
    """Each test finds the rig free, whatever the one before left (a failed test's seat)."""
    yield
    with instructor(server) as prof:
        prof.post("/rig/takeover")
        prof.post("/rig/clear")
        assert prof.delete("/rig/queue").json()["driver"] is None


def choose_rig(page: Page) -> None:
    """The flexible link's analysis page with the real rig chosen."""
    page.goto("/plants/flexible_link/analysis")
    page.get_by_test_id("rig-mode").get_by_label("Real rig").check()
    expect(page.get_by_test_id("rig-line")).to_contain_text("waiting")  # the queue is in


def test_the_start_page_shows_the_rig_as_emulated(page: Page, shots: Path) -> None:
    page.goto("/")
    status = page.get_by_test_id("rig-status")
    expect(status).to_be_visible()
    expect(status.locator(".rig-kind")).to_have_text("emulated rig")
    expect(page.get_by_test_id("rig-identity")).to_contain_text("not hardware")
    expect(page.get_by_test_id("rig-state")).to_have_text("free")
    expect(page.get_by_test_id("rig-details")).to_contain_text(re.compile(r"p99 \d+ µs"))
    # a student sees no instructor's buttons
    for name in ("Take over", "Clear queue", "Emergency stop"):
        expect(status.get_by_role("button", name=name)).to_be_hidden()
    page.screenshot(path=shots / "home-rig.png")


def test_a_student_runs_on_the_rig_and_presses_the_emergency_stop(
    page: Page, browser: Browser, server: Server, shots: Path
) -> None:
    choose_rig(page)
    queue = page.get_by_test_id("rig-queue")
    # Start before joining: nothing is sent, the rig's steps say what to do
    page.get_by_role("button", name="Start", exact=True).click()
    expect(queue.get_by_test_id("rig-error")).to_contain_text("Join the rig's queue first")
    expect(page.locator(".run-panel")).to_have_count(0)
    queue.get_by_role("button", name="Join the queue").click()
    expect(queue.get_by_test_id("rig-you")).to_have_text("Your turn: arm the rig to start.")
    expect(queue.get_by_text("Arm within")).to_contain_text(re.compile(r"Arm within \d:\d\d"))
    queue.get_by_role("button", name="Arm the rig").click()
    you = queue.get_by_test_id("rig-you")
    expect(you).to_have_text("You drive the rig: armed, start your run.")
    expect(queue.get_by_text("Your slot ends in")).to_contain_text(re.compile(r"\d:\d\d"))
    # long enough for the second person's steps below (over a minute beside two CPU hogs);
    # the emergency stop ends it
    page.locator("#f-duration").fill("200")
    page.get_by_role("button", name="Start", exact=True).click()
    panel = page.locator(".run-panel")
    # after the rig trial (five emulated rigs in a niced worker: seconds beside two CPU hogs)
    expect(panel.locator(".badge").first).to_have_text("running", timeout=120_000)
    rid = str(panel.get_attribute("data-run"))
    page.wait_for_function(f"() => {SAMPLES} > 500")  # it streams
    expect(panel.get_by_test_id("rig-latency")).to_contain_text(re.compile(r"p99 \d+ µs"))
    expect(panel.get_by_role("button", name="Pause")).to_have_count(0)  # a motor holds nothing

    # another person sees the rig in use, joins and sees their place
    with person(browser, server) as other:
        other.goto("/plants/flexible_link")
        status = other.get_by_test_id("rig-status")
        expect(other.get_by_test_id("rig-state")).to_have_text("in use")
        expect(other.get_by_test_id("rig-headline")).to_contain_text(
            re.compile(rf"In use by {GUEST} \(running a run\)")
        )
        expect(status.get_by_role("button", name="Emergency stop")).to_be_hidden()
        choose_rig(other)
        other.get_by_test_id("rig-queue").get_by_role("button", name="Join the queue").click()
        expect(other.get_by_test_id("rig-you")).to_contain_text(
            re.compile(r"You are 2nd in the queue: about \d+ (s|min)\.")
        )
        other.screenshot(path=shots / "analysis-rig-queue.png")
        # the driver's page hears of the waiting person with its next poll
        expect(queue.get_by_test_id("rig-line")).to_contain_text("1 waiting")
        other.get_by_test_id("rig-queue").get_by_role("button", name="Leave the queue").click()
        expect(other.get_by_test_id("rig-you")).to_have_text("You are not in the queue.")

    # the emergency stop: in view wherever the page is scrolled, pressed with the keyboard
    estop = page.get_by_test_id("estop")
    expect(estop).to_be_in_viewport()
    page.screenshot(path=shots / "analysis-rig-run.png")
    page.mouse.wheel(0, 5000)
    expect(estop).to_be_in_viewport()
    estop.focus()
    page.keyboard.press("Enter")
    expect(panel.locator(".badge").first).to_have_text("stopped")
    end = panel.get_by_test_id("rig-run-end")
    expect(end).to_contain_text("Emergency stop")
    expect(end).to_contain_text(re.compile(rf"emergency stop by {GUEST}"))
    expect(estop).to_be_hidden()
    # the whole run is in: its own latency channel, summed up
    expect(panel.get_by_test_id("rig-latency")).to_contain_text(
        re.compile(r"this run's loop latency: p50 \d+ µs · p99 \d+ µs")
    )
    # a rig run is shown beside its model's prediction at once: the nominal model, and the
    # gap over the whole run once it is in
    expect(panel.get_by_test_id("show-prediction")).to_be_checked()
    expect(panel.get_by_test_id("prediction")).to_contain_text("nominal linear model")
    with server.client() as c:
        n = c.get(f"/runs/{rid}").json()["n_samples"]
    expect(panel.get_by_test_id("prediction-gap")).to_contain_text(
        re.compile(rf"Run − prediction over {n:,} samples: servo angle θ: RMS [\d.]+°")
    )
    panel.get_by_test_id("prediction").screenshot(path=shots / "rig-prediction.png")
    # still seated: the next run needs arming again
    expect(queue.get_by_role("button", name="Arm the rig")).to_be_visible()
    with server.client() as c:
        run = c.get(f"/runs/{rid}").json()
    assert run["status"] == "stopped" and "emergency stop" in run["error"], run
    queue.get_by_role("button", name="Leave the queue").click()
    expect(queue.get_by_test_id("rig-you")).to_have_text("You are not in the queue.")


def test_an_instructor_takes_the_rig_over_from_the_status_panel(
    page: Page, browser: Browser, server: Server
) -> None:
    choose_rig(page)
    page.get_by_test_id("rig-queue").get_by_role("button", name="Join the queue").click()
    expect(page.get_by_test_id("rig-you")).to_have_text("Your turn: arm the rig to start.")
    with person(browser, server) as prof:
        prof.on("dialog", lambda d: d.accept())  # "Take the rig over from …?"
        prof.goto("/account")
        prof.get_by_label("Name").fill("prof")
        prof.get_by_label("Password").fill(PASSWORD)
        prof.get_by_role("button", name="Sign in").click()
        expect(prof.get_by_test_id("who")).to_have_text("prof · instructor")
        prof.goto("/plants/flexible_link")
        status = prof.get_by_test_id("rig-status")
        headline = prof.get_by_test_id("rig-headline")
        expect(headline).to_contain_text(re.compile(rf"In use by {GUEST}"))
        expect(status.get_by_role("button", name="Clear queue")).to_be_hidden()  # none waiting
        status.get_by_role("button", name="Take over").click()
        expect(headline).to_contain_text("In use by you (taken over)")
        expect(status.get_by_role("button", name="Extend +5 min")).to_be_visible()
        expect(status.get_by_role("button", name="Clear queue")).to_be_visible()  # the student
        # the student, displaced, waits first in line
        expect(page.get_by_test_id("rig-you")).to_contain_text("You are 2nd in the queue")
        status.get_by_role("button", name="Clear queue").click()
        expect(page.get_by_test_id("rig-you")).to_have_text("You are not in the queue.")
        with server.client() as c:  # the instructor's seat ends when the test does
            assert c.get("/rig").json()["driver"] == "prof (instructor)"
        prof.evaluate("fetch('/api/v1/rig/queue', {method: 'DELETE'})")
        expect(status.get_by_role("button", name="Take over")).to_be_visible()
