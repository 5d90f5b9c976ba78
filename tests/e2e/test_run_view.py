"""The run as a class watches it (issue 15): the plant's schematic moves with the stream, a
finished run replays, the parameter changes reach spectators live, and the run form and the
plot fit a 1280×800 screen, also in classroom mode. Checked on the data the page shows (the
schematic's transform, the sample it drew, the readout), not on pixels."""

from __future__ import annotations

import math
import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from playwright.sync_api import FloatRect, Page, expect

from tests.api.server import Server

POSITION = "[data-testid=replay-position]"
LABELS = """() => document.querySelector('[data-testid=live-plot]').layout
  .annotations?.map(a => a.text)"""
DRAWN = """() => { const svg = document.querySelector('[data-testid=schematic] svg');
  const arm = document.querySelector('[data-testid=schematic-arm]');
  const m = /rotate\\(([-\\d.e]+) /.exec(arm?.getAttribute('transform') ?? '');
  return svg?.dataset.k && m ? [Number(svg.dataset.k), Number(m[1])] : null; }"""
SAMPLES = "() => Number(document.querySelector('.progress')?.dataset.samples ?? 0)"
PLOT_END = """() => { const d = document.querySelector('[data-testid=live-plot]').data;
  return Math.max(...d.map(t => t.x.length ? t.x[t.x.length - 1] : 0)); }"""
K = [20, -93.5614, 3.3621, 0.9623]  # the flexible link's predefined gains
#: the live views at full motion here (30 draws a second; conftest.MOTION)
MOTION = "no-preference"


@pytest.fixture
def owner(server: Server) -> Iterator[httpx.Client]:
    with server.client() as c:
        yield c


def start(owner: httpx.Client, **body: Any) -> str:
    r = owner.post("/runs", json={"plant": "flexible_link", **body})
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def theta_deg(owner: httpx.Client, rid: str) -> np.ndarray:
    """The recorded servo angle θ in degrees, by sample."""
    data = owner.get(f"/runs/{rid}/data", params={"format": "json"}).json()
    assert data["k0"] == 0
    return np.degrees(np.asarray(data["data"]["theta"], dtype=np.float64))


def theta_deg_when_done(owner: httpx.Client, rid: str) -> np.ndarray:
    for _ in range(300):
        if owner.get(f"/runs/{rid}").json()["status"] == "finished":
            return theta_deg(owner, rid)
        time.sleep(0.1)
    raise AssertionError(f"run {rid} did not finish")


def drawn(page: Page) -> tuple[int, float]:
    page.wait_for_function(DRAWN)
    k, angle = page.evaluate(DRAWN)
    return int(k), float(angle)


def test_the_schematic_turns_with_the_streamed_angle(page: Page, owner: httpx.Client) -> None:
    rid = start(owner, duration=20)
    page.goto(f"/runs/{rid}")
    expect(page.get_by_test_id("schematic")).to_have_attribute("data-plant", "flexible_link")
    page.wait_for_function(f"() => ({SAMPLES})() >= 600")  # θ is on its way to +30°
    k1, a1 = drawn(page)
    page.wait_for_function(f"() => ({SAMPLES})() >= {k1} + 1800")  # past the edge at 2 s
    k2, a2 = drawn(page)
    owner.post(f"/runs/{rid}/stop")
    theta = theta_deg(owner, rid)
    assert k2 > k1 >= 0
    # the arm turns counter-clockwise by θ: SVG's rotate() is clockwise, so it reads −θ; the
    # transform has 3 decimals and the stream float32 (1e-6° at 30°)
    assert -a1 == pytest.approx(theta[k1], abs=2e-3)
    assert -a2 == pytest.approx(theta[k2], abs=2e-3)
    # it moved (how far depends on where in the square wave's period the page joined: one
    # run drew 16.42° then 17.06°, both exactly the recorded θ)
    assert abs(a2 - a1) > 0.1, (a1, a2)
    # the readout beside it shows the values of the sample drawn (read in one go: the last
    # frames may still be arriving)
    k, shown = page.evaluate(
        "() => { const r = document.querySelector('[data-testid=sample-readout]');"
        " return [Number(r.dataset.k),"
        " Number(r.querySelector('dd[data-channel=theta]').dataset.value)]; }"
    )
    assert shown == pytest.approx(theta[int(k)], abs=1e-4)


def test_a_finished_run_replays_and_scrubs(page: Page, owner: httpx.Client) -> None:
    rid = start(owner, duration=6, pace="fast")
    theta = theta_deg_when_done(owner, rid)
    page.goto(f"/runs/{rid}")
    replay = page.get_by_test_id("replay")
    expect(replay).to_be_visible(timeout=30_000)  # the whole recording is in the page
    scrubber = page.get_by_test_id("replay-position")
    assert int(scrubber.input_value()) == len(theta) - 1
    page.get_by_test_id("replay-speed").select_option("2")
    page.get_by_test_id("replay-play").click()
    page.wait_for_function(f"() => Number(document.querySelector('{POSITION}').value) > 200")
    first = int(scrubber.input_value())
    page.wait_for_function(f"() => Number(document.querySelector('{POSITION}').value) > {first}")
    second = int(scrubber.input_value())
    assert 0 < first < second <= len(theta) - 1  # it plays on from the start
    page.get_by_test_id("replay-play").click()  # pause
    # paused once the button says so (on a loaded machine the click's handler may run a
    # frame after the click returns)
    expect(page.get_by_test_id("replay-play")).to_have_attribute("aria-pressed", "false")
    paused = int(scrubber.input_value())
    page.wait_for_timeout(400)
    assert int(scrubber.input_value()) == paused

    scrubber.fill("1234")
    readout = page.get_by_test_id("sample-readout")
    expect(readout).to_have_attribute("data-k", "1234")
    expect(readout.locator("dd[data-channel=t]")).to_have_text("1.234 s")
    shown = float(str(readout.locator("dd[data-channel=theta]").get_attribute("data-value")))
    assert shown == pytest.approx(theta[1234], abs=1e-4)
    k, angle = drawn(page)
    assert k == 1234 and -angle == pytest.approx(theta[1234], abs=2e-3)
    # the plot draws the run up to that sample (at most: its last pixel column's min or max)
    page.wait_for_function(f"() => {{ const t = ({PLOT_END})(); return t > 1.2 && t < 1.2345; }}")
    expect(page.get_by_test_id("replay")).to_contain_text("t = 1.23 s of")


def test_a_run_beside_its_models_prediction(page: Page, owner: httpx.Client, shots: Path) -> None:
    """Noisy sensors: the run strays from its noise-free prediction by about the noise."""
    square = {"kind": "square", "amplitude": math.radians(30), "period": 2.0}
    rid = start(owner, pace="fast", duration=3, seed=5, signal=square)
    theta_deg_when_done(owner, rid)
    page.goto(f"/runs/{rid}")
    box = page.get_by_test_id("show-prediction")
    expect(box).not_to_be_checked()  # a simulation's prediction on request
    box.check()
    gap = page.get_by_test_id("prediction-gap")
    expect(gap).to_contain_text(
        re.compile(r"Run − prediction over 3,000 samples: servo angle θ: RMS [\d.]+°")
    )
    api = {g["name"]: g for g in owner.get(f"/runs/{rid}/prediction").json()["gaps"]}
    shown = float(re.search(r"servo angle θ: RMS ([\d.]+)°", gap.inner_text()).group(1))  # type: ignore[union-attr]
    assert shown == pytest.approx(math.degrees(api["theta"]["rms"]), rel=0.01)
    # the predicted traces drawn dotted over the run, run − prediction below, every sample
    page.wait_for_function(
        """() => document.querySelector('[data-testid=live-plot]').data
          .some(t => t.name.endsWith(', predicted') && t.line.dash === 'dot' && t.x.length)"""
    )
    page.wait_for_function(
        """() => { const d = document.querySelector('[data-testid=prediction-diff]').data;
          return d && d.length >= 2 && d.every(t => t.x.length > 0); }"""
    )
    page.get_by_test_id("prediction").screenshot(path=shots / "run-prediction.png")
    box.uncheck()
    expect(page.get_by_test_id("prediction")).to_be_hidden()


def test_spectators_see_each_change_arrive_with_what_it_changed(
    page: Page, owner: httpx.Client
) -> None:
    rid = start(owner, duration=30)
    page.goto(f"/runs/{rid}")  # a spectator: another browser than the owner's
    page.wait_for_function(f"() => ({SAMPLES})() >= 200")
    table = page.get_by_test_id("param-changes")
    expect(table).to_be_hidden()

    r = owner.post(
        f"/runs/{rid}/params",
        json={"controller": {"kind": "state_feedback", "K": [30, *K[1:]]}},
    )
    assert r.status_code == 200, r.text
    k = r.json()["k"]
    rows = table.locator("tbody tr")
    expect(rows).to_have_count(1)
    expect(rows.first).to_have_attribute("data-k", str(k))
    expect(rows.first).to_contain_text("K1 20 → 30 V/rad")

    square = {"kind": "square", "amplitude": math.radians(45), "period": 4}
    r = owner.post(f"/runs/{rid}/params", json={"signal": square})
    assert r.status_code == 200, r.text
    expect(rows).to_have_count(2)
    expect(rows.nth(1)).to_contain_text("reference amplitude 30 → 45°")
    # a change of many values at once: the table has it all, its mark whole values only
    r = owner.post(
        f"/runs/{rid}/params",
        json={
            "controller": {"kind": "state_feedback", "K": [31, -90, 3, 1]},
            "signal": {**square, "amplitude": math.radians(35)},
        },
    )
    assert r.status_code == 200, r.text
    expect(rows).to_have_count(3)
    expect(rows.nth(2)).to_contain_text("reference amplitude 45 → 35°")
    # each change is a labelled mark on the plot: what it set, never a number cut short
    page.wait_for_function(f"() => ({LABELS})()?.length === 3")
    labels = page.evaluate(LABELS)
    assert labels[:2] == ["K1 → 30 V/rad", "reference amplitude → 45°"], labels
    assert labels[2].startswith("K1 → 31 V/rad, ") and labels[2].endswith(" more"), labels
    assert all(len(label) <= 40 and "…" not in label for label in labels), labels
    owner.post(f"/runs/{rid}/stop")
    # the settings read in the page's units, not raw JSON
    settings = page.get_by_test_id("run-settings")
    expect(settings).to_contain_text("amplitude")
    expect(settings).to_contain_text("30°")
    expect(settings).to_contain_text("20 V/rad")


def inside(box: FloatRect | None, height: int = 800) -> bool:
    return box is not None and box["y"] >= 0 and box["y"] + box["height"] <= height


@pytest.mark.parametrize("classroom", [False, True])
def test_start_and_the_whole_plot_fit_1280x800(page: Page, classroom: bool) -> None:
    page.goto("/")
    page.evaluate(f"localStorage.setItem('elab.classroom', '{int(classroom)}')")
    page.goto("/plants/flexible_link/analysis")
    submit = page.locator("form.run-form button[type=submit]")
    expect(submit).to_be_visible()
    assert inside(submit.bounding_box()), submit.bounding_box()  # no scrolling to find it
    page.locator("#f-duration").fill("20")
    submit.click()
    plot = page.locator(".run-panel [data-testid=live-plot]")
    page.wait_for_function(f"() => ({SAMPLES})() >= 100")
    assert inside(submit.bounding_box()) and inside(plot.bounding_box())
    # down the form to its last field (where Start was): the run and Start stay in view
    end = page.evaluate(
        "() => document.querySelector('form.run-form').getBoundingClientRect().bottom"
        " + window.scrollY - window.innerHeight"
    )
    assert end > 0  # the form is taller than the screen
    for y in np.linspace(0, end, 4)[1:]:
        page.evaluate(f"window.scrollTo(0, {y})")
        page.wait_for_timeout(100)
        assert inside(submit.bounding_box()), (y, submit.bounding_box())
        assert inside(plot.bounding_box()), (y, plot.bounding_box())
    # Tab into the reference's Offset from the top: it scrolls clear of the sticky Start
    # bar (issue 27: the bar covered it)
    page.evaluate("window.scrollTo(0, 0)")
    page.locator("#f-signal-period").focus()
    page.keyboard.press("Tab")
    expect(page.locator("#f-signal-offset")).to_be_focused()
    field = page.locator("#f-signal-offset").bounding_box()
    bar = page.locator("form.run-form > .actions").bounding_box()
    assert field and bar and field["y"] + field["height"] <= bar["y"], (field, bar)
    page.get_by_role("button", name="Stop").click()


def test_classroom_mode_scales_every_text(page: Page) -> None:
    sizes = {}
    probe = """(sel) => parseFloat(getComputedStyle(document.querySelector(sel)).fontSize)"""
    selectors = ["body", ".panel h2", ".hint", ".field label", "header.page h1"]
    for on in (False, True):
        page.goto("/")
        page.evaluate(f"localStorage.setItem('elab.classroom', '{int(on)}')")
        page.goto("/plants/flexible_link/analysis")
        page.locator(".panel h2").first.wait_for()
        sizes[on] = {s: page.evaluate(probe, s) for s in selectors}
    for s in selectors:
        assert sizes[True][s] > sizes[False][s], (s, sizes)
    assert sizes[True][".panel h2"] > sizes[True]["body"]  # headings above body text
    assert sizes[True][".hint"] >= 16, sizes[True]  # the small print is readable too


def test_an_unstable_designs_run_says_how_it_went_on_its_page_and_in_the_list(
    page: Page, owner: httpx.Client, shots: Path
) -> None:
    """A pole at +5: the run ends "finished", and its page and the runs list say it sat at
    the actuator's limit and ran away, with the server's sentences."""
    from elab.design import design_place
    from elab.plants import get_plant

    K_bad = design_place(get_plant("flexible_link"), [5.0, -10, -20, -30]).K.ravel().tolist()
    rid = start(
        owner,
        pace="fast",
        duration=3,
        experiment="design",
        controller={"kind": "state_feedback", "K": K_bad},
        signal={"kind": "step", "amplitude": math.radians(30)},
    )
    theta_deg_when_done(owner, rid)
    page.goto(f"/runs/{rid}")
    expect(page.locator(".run-panel .badge").first).to_have_text("finished")
    marks = page.get_by_test_id("run-outcome")
    expect(marks.locator("li")).to_have_count(2, timeout=20_000)
    expect(marks.locator("li[data-kind=saturated]")).to_contain_text("±10 V")
    expect(marks.locator("li[data-kind=ran_away]")).to_contain_text("unstable, or a sign is wrong")
    expect(marks.locator("li[data-kind=ran_away]")).to_contain_text(re.compile(r"from t = \d"))
    marks.screenshot(path=shots / "run-outcome.png")
    page.goto("/runs")
    chip = page.locator(f"tr[data-run='{rid}'] [data-testid=outcome-chip]")
    expect(chip).to_have_text("⚠ saturated, ran away")
    assert "unstable, or a sign is wrong" in (chip.get_attribute("title") or "")


def test_two_runs_compared_by_link_and_their_csv_holds_both(
    page: Page, owner: httpx.Client, shots: Path
) -> None:
    """Issue 27's acceptance: two runs ticked in Runs open /compare; the same link in a
    fresh browser context (another visitor) draws both and saves one CSV holding both
    recordings, sample by sample."""
    square = {"kind": "square", "amplitude": math.radians(30), "period": 2.0}
    first = start(owner, pace="fast", duration=2, signal=square)
    softer = {"kind": "state_feedback", "K": [8.0, -40.0, 1.5, 0.4]}
    second = start(owner, pace="fast", duration=1.5, signal=square, controller=softer)
    rec = {rid: theta_deg_when_done(owner, rid) for rid in (first, second)}
    page.goto("/runs")
    link = page.get_by_test_id("compare-link")
    expect(link).to_have_attribute("aria-disabled", "true")
    for rid in (first, second):
        page.get_by_label(f"compare run {rid}").check()
    expect(link).to_have_attribute("aria-disabled", "false")
    href = link.get_attribute("href")
    assert href is not None and set(href.split("=")[1].split(",")) == {first, second}

    # the link alone, in a fresh context: another visitor sees the same comparison
    browser = page.context.browser
    assert browser is not None
    other = browser.new_context(base_url=page.url.split("/runs")[0], accept_downloads=True)
    try:
        fresh = other.new_page()
        fresh.goto(f"/compare?runs={first},{second}")
        plot = fresh.get_by_test_id("compare-plot")
        expect(plot).to_be_visible()
        fresh.wait_for_function(
            "() => (document.querySelector('[data-testid=compare-plot]')?.data || []).length"
        )
        names = plot.evaluate("d => d.data.map(t => t.name)")
        tags = [n[:3] for n in names]
        assert tags.count("a: ") == tags.count("b: ") == 3, names
        expect(fresh.locator("[data-compare=b] table.settings")).to_contain_text("K")
        fresh.screenshot(path=shots / "compare.png", full_page=True)
        with fresh.expect_download() as info:
            fresh.get_by_test_id("compare-csv").click()
        text = Path(info.value.path()).read_text()
    finally:
        other.close()
    lines = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    header = lines[0].split(",")
    rows = [ln.split(",") for ln in lines[1:]]
    assert len(rows) == max(rec[first].size, rec[second].size) == 2000
    a_theta, b_theta = header.index("a:theta (rad)"), header.index("b:theta (rad)")
    got_a = np.degrees([float(r[a_theta]) for r in rows])
    got_b = np.degrees([float(r[b_theta]) for r in rows if r[b_theta]])
    np.testing.assert_allclose(got_a, rec[first], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got_b, rec[second], rtol=0, atol=1e-9)
    # the same link with a run of another plant, or one run, says why not
    belt = start(owner, plant="belt_conveyor", pace="fast", duration=0.5)
    page.goto(f"/compare?runs={first},{belt}")
    expect(page.get_by_test_id("compare-error")).to_contain_text("compare runs of one plant")


def test_a_run_presented_on_a_projector_is_mostly_plot(
    page: Page, owner: httpx.Client, shots: Path
) -> None:
    """Issue 27, item 4: at 1920×1080 in classroom mode, Present leaves the run alone on
    the screen: the live plot covers at least 80 % of the viewport, the plant drawing sits
    over its top left corner, the controls are folded away; Esc brings the page back."""
    square = {"kind": "square", "amplitude": math.radians(30), "period": 2.0}
    rid = start(owner, pace="fast", duration=3, signal=square)
    theta_deg_when_done(owner, rid)
    page.set_viewport_size({"width": 1920, "height": 1080})
    page.goto("/")
    page.evaluate("localStorage.setItem('elab.classroom', '1')")
    page.goto(f"/runs/{rid}")
    expect(page.locator(".run-panel .badge").first).to_have_text("finished")
    page.get_by_test_id("present").click()
    plot = page.get_by_test_id("live-plot")
    page.wait_for_function(
        """() => { const d = document.querySelector('[data-testid=live-plot]');
          const r = d.getBoundingClientRect();
          return r.height > 900 && d._fullLayout
            && Math.abs(d._fullLayout.height - r.height) < 2
            && Math.abs(d._fullLayout.width - r.width) < 2; }"""
    )
    box = plot.bounding_box()
    assert box is not None
    assert box["width"] * box["height"] >= 0.8 * 1920 * 1080, box
    drawing = page.get_by_test_id("schematic").bounding_box()
    # over the top left corner (the oldest samples), not the newest at the right edge
    assert drawing is not None and drawing["x"] + drawing["width"] < box["x"] + box["width"] / 2
    expect(page.get_by_role("button", name="Model prediction")).to_have_count(0)
    expect(page.locator(".run-panel .toolbar")).to_be_hidden()
    page.screenshot(path=shots / "run-presented.png")
    page.keyboard.press("Escape")
    expect(page.get_by_test_id("present")).to_have_text("Present")
    expect(page.locator(".run-panel .toolbar")).to_be_visible()
    small = plot.bounding_box()
    assert small is not None and small["height"] < box["height"]


def test_a_presenter_steps_through_the_chapters_runs_with_one_key(
    page: Page, owner: httpx.Client, shots: Path
) -> None:
    """Issue 27, item 4: *Present the lesson* starts the chapter's first run (the plant
    alone) on the whole screen; one key (Page Down, what a presenter's clicker sends, or →)
    stops it and starts the next: the arbitrary gain, then the LQR, each with its caption
    and the settings the plant's lesson gives."""
    lesson = owner.get("/plants/flexible_link").json()["lesson"]
    page.set_viewport_size({"width": 1920, "height": 1080})
    page.goto("/plants/flexible_link/analysis")
    page.get_by_test_id("present-lesson").click()
    runs: list[str] = []
    for i, key in enumerate(["PageDown", "ArrowRight", None]):
        panel = page.locator(".run-panel.presenting")
        caption = panel.get_by_test_id("lesson-caption")
        expect(caption).to_contain_text(f"{i + 1} of 3 · {lesson[i]['title']}")
        rid = panel.get_attribute("data-run")
        assert rid and rid not in runs
        runs.append(rid)
        page.wait_for_function(f"() => ({SAMPLES})() > 200")  # it streams
        if i == 1:
            page.screenshot(path=shots / "lesson-presented.png")
        if key:
            page.keyboard.press(key)
            expect(page.locator(f".run-panel.presenting:not([data-run='{rid}'])")).to_be_attached()
    expect(page.locator(".run-panel.presenting [data-testid=lesson-caption]")).to_contain_text(
        "the last step"
    )
    page.keyboard.press("PageDown")  # after the last step: nothing more starts
    # the last step goes on until Stop: the toolbar is folded away, not the way to stop it
    assert owner.get(f"/runs/{runs[-1]}").json()["status"] == "running"
    expect(page.locator(".run-panel.presenting .toolbar")).to_be_hidden()
    page.locator(".run-panel.presenting").get_by_test_id("present-stop").click()
    expect(page.locator(".run-panel.presenting .run-bar .badge").first).to_have_text("stopped")
    assert owner.get(f"/runs/{runs[-1]}").json()["status"] == "stopped"
    page.keyboard.press("Escape")
    expect(page.get_by_test_id("present")).to_have_text("Present")
    for rid, step in zip(runs, lesson, strict=True):
        run = owner.get(f"/runs/{rid}").json()
        assert run["request"]["controller"] == step["controller"], run["request"]
        assert run["request"]["duration"] == step["duration"]
    # each key stopped the step before it
    assert [owner.get(f"/runs/{r}").json()["status"] for r in runs[:2]] == ["stopped"] * 2


CUT_INPUTS = """() => [...document.querySelectorAll(
    'main input:not([type=checkbox]):not([type=radio]):not([type=range]):not([type=file]),'
    + 'main select')]
  .filter(e => e.offsetParent !== null && e.scrollWidth > e.clientWidth + 1)
  .map(e => `${e.id || e.name || e.getAttribute('aria-label')}: ${e.value}`)"""


@pytest.mark.parametrize("width,height", [(1920, 1080), (1280, 800)])
@pytest.mark.parametrize("view", ["analysis", "design", "identification"])
def test_no_input_is_cut_off_in_classroom_mode(
    page: Page, view: str, width: int, height: int
) -> None:
    """Issue 27: in classroom mode the gain fields showed "-93.561" of -93.5614. Every
    visible input and select shows its whole value (its scroll width within its box)."""
    page.set_viewport_size({"width": width, "height": height})
    page.goto("/")
    page.evaluate("localStorage.setItem('elab.classroom', '1')")
    page.goto(f"/plants/flexible_link/{view}")
    page.locator("main .field input").first.wait_for()
    if view == "design":
        page.get_by_role("button", name="Design").click()
        expect(page.get_by_test_id("gain")).to_contain_text("K = [")
    assert page.evaluate(CUT_INPUTS) == []
