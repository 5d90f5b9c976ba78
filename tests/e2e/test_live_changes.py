"""Issue 15 in the browser: Apply changes the reference at a recorded sample and says what
changed; fields a running run cannot change are disabled; the pendulum's default run moves
every output; the forms refuse hex numbers and runs too short to show anything; the
identification page measures like real sensors by default and says so."""

from __future__ import annotations

import math
import re

import httpx
import numpy as np
from playwright.sync_api import Page, expect

from tests.api.server import Server
from tests.e2e.test_app import run_id, samples, wait_samples

VISIBLE = math.radians(0.25)  # about 3 encoder counts of 0.088°: a motion a student sees


def test_apply_of_a_new_amplitude_changes_the_reference_at_the_recorded_sample(
    page: Page, server: Server
) -> None:
    page.goto("/plants/flexible_link/analysis")
    expect(page.locator("#f-signal-amplitude")).to_have_value("30")
    page.locator("#f-duration").fill("60")
    page.get_by_role("button", name="Start").click()
    wait_samples(page, 500)
    expect(page.locator("#f-duration")).to_be_disabled()  # fixed while the run goes
    page.locator("#f-signal-amplitude").fill("60")
    page.get_by_role("button", name="Apply changes to the running run").click()
    note = page.get_by_test_id("applied")
    expect(note).to_contain_text("reference amplitude 30 → 60°")
    k = int(re.search(r"k = (\d+)", note.inner_text()).group(1))  # type: ignore[union-attr]
    assert "K1" not in note.inner_text()  # the gains did not change, and it does not say so
    page.get_by_role("button", name="Apply changes to the running run").click()
    expect(note).to_contain_text("Nothing changed")
    wait_samples(page, k + 200)
    page.get_by_role("button", name="Stop").click()
    expect(page.locator(".run-panel .badge")).to_have_text("stopped")
    expect(page.locator("#f-duration")).to_be_enabled()

    rid = run_id(page)
    info = httpx.get(f"{server.url}/api/v1/runs/{rid}").json()
    assert [c["k"] for c in info["param_changes"]] == [k]
    assert list(info["param_changes"][0]["params"]) == ["signal"]
    r = np.array(
        httpx.get(f"{server.url}/api/v1/runs/{rid}/data?format=json&channels=r").json()["data"]["r"]
    )
    # the recorded reference: ±30° before sample k, ±60° from sample k on
    np.testing.assert_allclose(np.abs(r[:k]), math.radians(30), rtol=1e-9)
    np.testing.assert_allclose(np.abs(r[k:]), math.radians(60), rtol=1e-9)


def test_the_pendulums_default_run_moves_every_output(page: Page, server: Server) -> None:
    page.goto("/plants/double_pendulum/analysis")
    expect(page.locator("#f-duration")).to_have_value("130")  # until the disc has settled
    expect(page.locator("#f-x0-1")).to_have_value("0.5")  # pendulum 1 released 0.5° off
    # the step plots: α on its own axes, β₁ and β₂ on others; the open loop cut with a note
    expect(page.get_by_test_id("step-closed-axes-1").locator(".main-svg").first).to_be_visible()
    expect(page.get_by_test_id("step-open-cut")).to_contain_text("β₁ from upright leaves -10 … 10°")
    page.get_by_role("button", name="Start").click()
    wait_samples(page, 3000, timeout=30_000)
    rid = run_id(page)
    data = httpx.get(f"{server.url}/api/v1/runs/{rid}/data?format=json").json()["data"]
    page.get_by_role("button", name="Stop").click()
    # within its first 3 s already, each output moves by more than VISIBLE
    for name in ("alpha", "beta1", "beta2"):
        assert np.ptp(data[name]) > VISIBLE, (name, np.ptp(data[name]))
    assert samples(page) >= 3000


def test_forms_refuse_hex_numbers_and_runs_too_short_to_show(page: Page) -> None:
    page.goto("/plants/flexible_link/analysis")
    posts: list[str] = []
    page.on("request", lambda r: posts.append(r.url) if r.method == "POST" else None)
    page.locator("#f-signal-amplitude").fill("0x10")
    expect(page.locator("#f-signal-amplitude-error")).to_contain_text(
        '"0x10" is not a number ≥ -360 and ≤ 360 (write it in decimal digits)'
    )
    page.locator("#f-duration").fill("1e-9")
    expect(page.locator("#f-duration-error")).to_contain_text("allowed: a number ≥ 0.01")
    page.locator("#f-signal-period").fill("0.001")
    expect(page.locator("#f-signal-period-error")).to_contain_text("≥ 0.004")
    page.get_by_role("button", name="Start").click()
    expect(page.get_by_test_id("form-error")).to_contain_text("nothing was sent")
    assert [u for u in posts if u.endswith("/runs")] == []


def test_identification_runs_with_realistic_sensors_by_default(page: Page, server: Server) -> None:
    page.goto("/plants/flexible_link/identification")
    box = page.get_by_label("Realistic sensors")
    expect(box).to_be_checked()
    expect(page.locator("#sensors-hint")).to_contain_text("noise (theta 0.0115°, alpha 0.0115°")
    page.locator("#f-duration").fill("1")
    page.get_by_role("button", name="Start").click()
    expect(page.locator(".run-panel .badge")).to_have_text("finished", timeout=20_000)
    expect(page.get_by_test_id("sensors")).to_contain_text("quantised to theta 0.0879°")
    rid = run_id(page)
    head = httpx.get(f"{server.url}/api/v1/runs/{rid}/data").text.splitlines()
    assert any(line.startswith("# noise: white, standard deviation theta") for line in head)
    assert "# quantisation: theta 0.00153398 rad, alpha 0.00153398 rad (the sensors' " in "\n".join(
        head
    )
    box.uncheck()  # switched off: exact outputs, and the page and the download say so
    page.get_by_role("button", name="Start").click()
    expect(page.get_by_test_id("sensors")).to_contain_text("(ideal sensors)", timeout=20_000)
    rid2 = run_id(page)
    assert rid2 != rid
    head = httpx.get(f"{server.url}/api/v1/runs/{rid2}/data").text
    assert "# noise: none (ideal sensors)" in head and "# quantisation: none" in head


COUNT_DRAWS = """() => new Promise(done => {
  const plot = document.querySelector('[data-testid=live-plot]');
  const svg = document.querySelector('[data-testid=schematic] svg');
  const progress = document.querySelector('.progress');
  const n = {plot: 0, schematic: 0, progress: 0};
  plot.addEventListener('elab:draw', () => n.plot++);
  const count = (what) => new MutationObserver((records) => { n[what] += records.length; });
  count('schematic').observe(svg, {attributes: true, attributeFilter: ['data-k']});
  count('progress').observe(progress, {attributes: true, attributeFilter: ['data-samples']});
  const t0 = performance.now();
  setTimeout(() => done({...n, seconds: (performance.now() - t0) / 1000}), 3000);
})"""


def test_a_reader_who_asks_for_less_motion_sees_five_draws_a_second(
    page: Page, server: Server
) -> None:
    """prefers-reduced-motion (the suite's pages ask for it, tests/e2e/conftest.py): the
    live plot, the schematic and the progress line follow a live run 5 times a second at
    most instead of 30 (at every one of its 50 messages a second, for the progress line),
    and still follow it."""
    with server.client() as owner:
        rid = owner.post("/runs", json={"plant": "flexible_link", "duration": 30}).json()["id"]
        page.goto(f"/runs/{rid}")
        assert page.evaluate("matchMedia('(prefers-reduced-motion: reduce)').matches")
        page.wait_for_function(
            "() => Number(document.querySelector('.progress')?.dataset.samples ?? 0) >= 200"
        )
        counts = page.evaluate(COUNT_DRAWS)
        owner.post(f"/runs/{rid}/stop")
    most = 5 * counts["seconds"] + 1  # one every 200 ms at most, and the first at once
    for what in ("plot", "schematic", "progress"):
        assert 1 <= counts[what] <= most, counts
