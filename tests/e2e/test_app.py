"""The lab in the browser, as a student and a spectator use it (issue 4's acceptance)."""

from __future__ import annotations

import csv
import io
import re
import time
from pathlib import Path
from typing import Any

import control as ct
import httpx
import numpy as np
import pytest
from playwright.sync_api import Browser, Page, expect

from tests.api.server import Server, identification_run
from tests.e2e.proxy import BlipProxy

SAMPLES = "() => Number(document.querySelector('.progress')?.dataset.samples ?? 0)"
PLOT_END = """() => { const d = document.querySelector('[data-testid=live-plot]').data;
  return d ? Math.max(...d.map(t => t.x.length ? t.x[t.x.length - 1] : 0)) : 0; }"""


def samples(page: Page) -> int:
    return int(page.evaluate(SAMPLES))


def wait_samples(page: Page, at_least: int, timeout: float = 20_000) -> None:
    page.wait_for_function(f"() => ({SAMPLES})() >= {at_least}", timeout=timeout)


def run_id(page: Page) -> str:
    return str(page.get_attribute(".run-panel", "data-run"))


def test_home_lists_every_plant_and_experiment(page: Page, server: Server, shots: Path) -> None:
    page.goto("/")
    cards = page.locator("article.card")
    expect(cards).to_have_count(3)
    names = {c.get_attribute("data-plant") for c in cards.all()}
    assert names == {"flexible_link", "double_pendulum", "belt_conveyor"}
    for card in cards.all():
        expect(card.locator("ul.experiments a")).to_have_count(3)
    page.screenshot(path=shots / "home.png", full_page=True)
    page.get_by_role("link", name="Rotary flexible link").click()
    expect(page).to_have_url(re.compile(r"/plants/flexible_link$"))
    expect(page.locator(".description .katex").first).to_be_visible()  # equations rendered
    page.screenshot(path=shots / "plant.png", full_page=True)


def test_analysis_run_live_gain_change_stop_download_and_spectator(
    page: Page, browser: Browser, server: Server, shots: Path
) -> None:
    page.goto("/")
    page.locator("[data-plant=flexible_link]").get_by_role("link", name="System analysis").click()
    heading = page.get_by_role("heading", name="Rotary flexible link: system analysis")
    expect(heading).to_be_visible()
    # the form is pre-filled with the predefined gains and the default ±30° square wave
    expect(page.locator("#f-controller-K-1")).to_have_value("-93.5614")
    expect(page.locator("#f-signal-amplitude")).to_have_value("30")
    expect(page.locator("[data-verdict]")).to_contain_text("marginally stable")

    page.locator("#f-duration").fill("60")  # long enough to be stopped by hand
    page.get_by_role("button", name="Start").click()
    wait_samples(page, 1000)
    first = page.evaluate(PLOT_END)
    wait_samples(page, samples(page) + 500)
    page.wait_for_function(f"() => ({PLOT_END})() > {first}")  # the plot advances
    legend = page.locator("[data-testid=live-plot] .legend")
    for label in ("reference r", "servo angle θ", "link deflection α", "control u"):
        expect(legend).to_contain_text(label)
    rid = run_id(page)

    spectator = browser.new_context(
        viewport={"width": 1280, "height": 800}, base_url=server.url, accept_downloads=True
    ).new_page()
    spectator.goto(f"/runs/{rid}")
    wait_samples(spectator, 1)

    page.locator("#f-controller-K-0").fill("30")
    page.get_by_role("button", name="Apply changes to the running run").click()
    note = page.get_by_test_id("applied")
    expect(note).to_contain_text("applied from sample k =")
    k = int(re.search(r"k = (\d+)", note.inner_text()).group(1))  # type: ignore[union-attr]
    wait_samples(page, k + 300)
    page.screenshot(path=shots / "analysis.png", full_page=True)
    page.get_by_role("button", name="Stop").click()
    expect(page.locator(".run-panel .badge")).to_have_text("stopped")

    info = httpx.get(f"{server.url}/api/v1/runs/{rid}").json()
    assert info["status"] == "stopped"
    assert [c["k"] for c in info["param_changes"]] == [k]
    assert info["param_changes"][0]["params"]["controller"]["K"][0] == 30
    n = info["n_samples"]
    wait_samples(page, n)
    assert samples(page) == n

    with page.expect_download() as dl:
        page.get_by_test_id("download-csv").click()
    text = Path(dl.value.path()).read_text()
    assert text == httpx.get(f"{server.url}/api/v1/runs/{rid}/data?format=csv").text
    head = [line for line in text.splitlines() if line.startswith("#")]
    assert any("flexible_link" in line for line in head)
    rows = list(
        csv.reader(
            io.StringIO("\n".join(line for line in text.splitlines() if not line.startswith("#")))
        )
    )
    assert len(rows) == n + 1  # the column header and every sample
    assert rows[0][0].startswith("t")

    # the spectator followed the same run and holds the same samples
    wait_samples(spectator, n)
    expect(spectator.locator(".run-panel .badge")).to_have_text("stopped")
    spectator.screenshot(path=shots / "run.png", full_page=True)
    mine = plot_data(page).splitlines()
    theirs = plot_data(spectator).splitlines()
    assert len(mine) == n + 1
    # a late joiner starts 10 s before the live edge (runpanel.ts firstSeq): on a loaded
    # machine the spectator's page opened more than 10 s into the run, so it may hold the
    # run's last samples only; those are the owner's, row for row
    assert theirs[0] == mine[0]  # the same columns
    held = len(theirs) - 1
    assert held >= min(n, 10_000), held
    assert theirs[1:] == mine[len(mine) - held :]
    spectator.context.close()


def plot_data(page: Page) -> str:
    with page.expect_download() as dl:
        page.get_by_role("button", name="plot data").click()
    return Path(dl.value.path()).read_text()


def test_invalid_input_shows_a_message_and_sends_nothing(page: Page) -> None:
    page.goto("/plants/flexible_link/analysis")
    posts: list[str] = []
    page.on("request", lambda r: posts.append(r.url) if r.method == "POST" else None)
    gain = page.locator("#f-controller-K-1")
    gain.fill("abc")
    expect(page.locator(".field.invalid .error")).to_contain_text('"abc" is not a number')
    page.locator("#f-duration").fill("-5")
    expect(page.locator(".field.invalid")).to_have_count(2)
    page.get_by_role("button", name="Start").click()
    expect(page.get_by_test_id("form-error")).to_contain_text("nothing was sent")
    page.wait_for_timeout(500)
    assert [u for u in posts if u.endswith("/runs")] == []


def test_server_errors_show_next_to_their_field(page: Page) -> None:
    page.goto("/plants/flexible_link/analysis")
    page.locator("#f-duration").fill("4000")  # the form allows ≤ 3600: refused locally
    expect(page.locator("#f-duration-error")).to_contain_text("allowed: a number ≥ 0.01 and ≤ 3600")


def page_identification(server: Server, rid: str, **asked: Any) -> Any:
    """The API's answer to what the identification page sends for a link run by default
    (θ from u, about the plant's rest, the link's every 10th sample of its 1 kHz run, both
    order searches), with ``asked`` (the models, a closed-loop method) added."""
    body = {
        "data": {"source": "run", "run": rid, "input": ["u"], "output": ["theta"]},
        "detrend": "operating_point",
        "decimate": 10,
        "arx_search": {"na": [1, 10], "nb": [1, 10], "nk": [1, 10]},
        "n4sid_orders": [1, 10],
    }
    return httpx.post(f"{server.url}/api/v1/ident", timeout=60, json=body | asked).json()


def test_identification_run_and_data_set(page: Page, server: Server, shots: Path) -> None:
    page.goto("/plants/flexible_link/identification")
    expect(page.locator("#excitation-kind")).to_have_value("prbs")
    page.locator("#f-duration").fill("2")
    page.get_by_role("button", name="Start").click()
    expect(page.locator(".run-panel .badge")).to_have_text("finished", timeout=20_000)
    expect(page.locator(".handover")).to_contain_text("2,000 at Ts = 1 ms")
    rid = run_id(page)
    req = httpx.get(f"{server.url}/api/v1/runs/{rid}").json()["request"]
    assert req["experiment"] == "identification"
    assert req["excitation"]["kind"] == "prbs" and req["excitation_at"] == "input"
    # the analysis of this run, in the page, equals the API's answer to the same request
    panel = page.get_by_test_id("ident-run")
    # the link integrates and its runs start at rest: its rest is taken off (0 here)
    expect(panel.locator("#id-detrend")).to_have_value("operating_point")
    expect(panel.get_by_test_id("detrend-why")).to_contain_text("a ramp the plant never made")
    expect(panel.locator("#id-models")).to_have_value("oe:4,4,1; n4sid:4")
    expect(panel.locator("#id-decimate")).to_have_value("10")
    expect(panel.get_by_test_id("ident-proposed-why")).to_contain_text("resonance is at 3 Hz")
    panel.locator("#id-models").fill("arx:4,4,1; bj:1,1")
    panel.get_by_role("button", name="Identify").click()
    expect(panel.get_by_test_id("models-error")).to_contain_text("arx, armax, oe, n4sid or link")
    panel.locator("#id-models").fill("arx:4,4,1; n4sid:4")
    panel.get_by_role("button", name="Identify").click()
    table = panel.get_by_test_id("ident-models")
    expect(table).to_contain_text("n4sid 4", timeout=60_000)
    api = page_identification(
        server,
        rid,
        models=[
            {"kind": "arx", "na": 4, "nb": 4, "nk": 1},
            {"kind": "n4sid", "order": 4, "horizon": 0},
        ],
    )
    for i, m in enumerate(api["models"]):
        cells = table.locator("tbody tr").nth(i).locator("td")
        shown = float(cells.first.inner_text().split()[0])
        assert shown == pytest.approx(
            m["fit"]["validation_simulation"][0], abs=1e-3 * max(1, abs(shown))
        )
    for testid in (
        "ident-data",
        "ident-impulse",
        "ident-spectral",
        "ident-arx-search",
        "ident-singular-values",
        "ident-compare",
        "ident-resid-arx",
    ):
        expect(panel.get_by_test_id(testid).locator(".main-svg").first).to_be_visible()
    page.screenshot(path=shots / "identification.png", full_page=True)
    verdicts = panel.get_by_test_id("data-verdicts")
    expect(verdicts.locator("[data-topic=feedback]")).to_contain_text("closed loop")
    verdicts.screenshot(path=shots / "ident-verdicts.png")
    # "use this model": kept on the server, its design page shows it beside the physics model
    level = panel.get_by_test_id("model-level-1").inner_text()
    panel.get_by_test_id("use-model-1").click()
    if level == "poor":  # a poor model is kept on the second click, after the warning
        expect(page.get_by_test_id("poor-model-warning")).to_be_visible()
        panel.get_by_test_id("use-model-1").click()
    expect(page).to_have_url(re.compile(r"/plants/flexible_link/design\?model=m-[0-9a-f]+$"))
    panel = page.get_by_test_id("identified-model")
    expect(panel).to_contain_text("Identified model: n4sid 4")
    expect(panel.locator(".katex").first).to_be_visible()
    expect(page.get_by_test_id("identified-step").locator(".main-svg").first).to_be_visible()
    page.screenshot(path=shots / "design-identified.png", full_page=True)


def test_the_two_stage_method_from_the_page_equals_the_apis(page: Page, server: Server) -> None:
    """Closed loop, *Method: two-stage*: the page sends the run's two-stage request with
    its taps (a second at the link's 1 kHz), says what was done in the notes and the
    data verdicts, and shows the API's fits; too many taps for a short run are refused
    beside the taps field."""
    page.goto("/plants/flexible_link/identification")
    page.locator("#f-duration").fill("6")
    page.get_by_role("button", name="Start").click()
    expect(page.locator(".run-panel .badge")).to_have_text("finished", timeout=30_000)
    rid = run_id(page)
    panel = page.get_by_test_id("ident-run")
    expect(panel.locator("#id-two_stage")).to_have_value("1000")
    panel.get_by_test_id("ident-method").select_option("two_stage")
    panel.locator("#id-models").fill("oe:4,4,1")
    panel.locator("#id-two_stage").fill("2000")  # the form's own limit: 1000
    panel.get_by_role("button", name="Identify").click()
    expect(panel.locator("#id-two_stage-error")).to_contain_text("≤ 1000")
    panel.locator("#id-split").fill("0.25")  # 1,500 estimation samples bear 749 taps
    panel.locator("#id-two_stage").fill("1000")
    panel.get_by_role("button", name="Identify").click()
    expect(panel.locator("#id-two_stage-error")).to_contain_text("at most 749 taps")
    panel.locator("#id-split").fill("0.5")
    panel.get_by_role("button", name="Identify").click()
    table = panel.get_by_test_id("ident-models")
    expect(table).to_contain_text("oe 4 4 1", timeout=60_000)
    expect(panel).to_contain_text("two-stage method: the estimation part's u replaced")
    verdicts = panel.get_by_test_id("data-verdicts")
    expect(verdicts.locator("[data-topic=two_stage]")).to_contain_text("the references explain")
    expect(verdicts.locator("[data-topic=feedback]")).to_contain_text("two-stage method")
    api = page_identification(
        server, rid, two_stage=1000, models=[{"kind": "oe", "nb": 4, "nf": 4, "nk": 1}]
    )
    shown = float(table.locator("tbody tr").first.locator("td").first.inner_text().split()[0])
    want = api["models"][0]["fit"]["validation_simulation"][0]
    assert shown == pytest.approx(want, abs=1e-3 * max(1, abs(shown)))


def test_identification_from_a_file_reproduces_the_dryer_results(page: Page) -> None:
    page.goto("/plants/flexible_link/identification")
    page.get_by_text("Or identify from a data file").click()
    panel = page.get_by_test_id("ident-file")
    panel.get_by_role("button", name="Identify").click()
    expect(panel.get_by_test_id("ident-error")).to_contain_text("Choose a data file")
    dryer = Path(__file__).resolve().parents[1] / "reference" / "ident" / "dryer.dat"
    panel.locator("#idf-file").set_input_files(str(dryer))
    panel.locator("#idf-input-cols").fill("c1")
    panel.locator("#idf-output-cols").fill("c3")
    panel.locator("#idf-data-Ts").fill("0.08")
    panel.locator("#idf-models").fill("arx:2,2,3; n4sid:4,16")
    panel.get_by_role("button", name="Identify").click()
    expect(panel.get_by_test_id("ident-error")).to_contain_text("c1, c2")  # no column c3
    panel.locator("#idf-output-cols").fill("c2")
    panel.get_by_role("button", name="Identify").click()
    rows = panel.get_by_test_id("ident-models").locator("tbody tr")
    expect(rows.nth(0)).to_contain_text("arx 2 2 3", timeout=60_000)
    assert float(rows.nth(0).locator("td").first.inner_text().split()[0]) == pytest.approx(
        89.55, abs=0.3
    )  # published (README)
    assert float(rows.nth(1).locator("td").first.inner_text().split()[0]) >= 89
    expect(panel.get_by_test_id("ident-results")).to_contain_text("a delay of 3 samples")


def test_the_indirect_method_from_a_file_on_the_page(
    page: Page, server: Server, tmp_path: Path
) -> None:
    """A closed-loop record (u = r − 0.6 y) as a file, *Method: indirect* with C = 0.6:
    the page's model is the API's plant; a controller that is not numbers is refused
    before anything is sent."""
    from tests.unit.ident.test_closedloop import closed_loop

    data, _ = closed_loop(15)
    table = tmp_path / "loop.csv"
    np.savetxt(table, np.column_stack([data.u, data.y]), delimiter=",", header="u,y", comments="")
    page.goto("/plants/flexible_link/identification")
    page.get_by_text("Or identify from a data file").click()
    panel = page.get_by_test_id("ident-file")
    panel.locator("#idf-file").set_input_files(str(table))
    panel.locator("#idf-data-Ts").fill("0.01")
    panel.locator("#idf-detrend").select_option("none")
    panel.locator("#idf-models").fill("oe:1,1,1")
    panel.get_by_test_id("ident-method").select_option("indirect")
    panel.locator("#idf-indirect-num").fill("0.6 x")
    panel.get_by_role("button", name="Identify").click()
    expect(panel.get_by_test_id("ident-error")).to_contain_text("The controller's numerator")
    panel.locator("#idf-indirect-num").fill("0.6")
    panel.get_by_role("button", name="Identify").click()
    rows = panel.get_by_test_id("ident-models").locator("tbody tr")
    expect(rows.nth(0)).to_contain_text("oe 1 1 1 (indirect)", timeout=60_000)
    expect(panel).to_contain_text("indirect method: the models were fitted to the loop")
    api = httpx.post(
        f"{server.url}/api/v1/ident",
        timeout=60,
        json={
            "data": {
                "source": "file",
                "name": "loop.csv",
                "text": table.read_text(),
                "input": ["u"],
                "output": ["y"],
                "Ts": 0.01,
            },
            "detrend": "none",
            "arx_search": {"na": [1, 10], "nb": [1, 10], "nk": [1, 10]},
            "n4sid_orders": [1, 10],
            "indirect": {"num": [0.6], "den": [1]},
            "models": [{"kind": "oe", "nb": 1, "nf": 1, "nk": 1}],
        },
    ).json()
    shown = float(rows.nth(0).locator("td").first.inner_text().split()[0])
    want = api["models"][0]["fit"]["validation_simulation"][0]
    assert shown == pytest.approx(want, abs=1e-3 * max(1, abs(shown)))


def test_design_lqr_compare_and_run(page: Page, server: Server, shots: Path) -> None:
    page.goto("/plants/flexible_link/design")
    page.get_by_role("button", name="Design").click()
    gain = page.get_by_test_id("gain")
    expect(gain).to_contain_text("K = [")
    ref = httpx.post(
        f"{server.url}/api/v1/plants/flexible_link/design/lqr", json={"Q": [400, 1e4, 3, 2], "R": 1}
    ).json()["K"]
    shown = [float(v) for v in re.findall(r"-?[\d.]+(?:e-?\d+)?", gain.inner_text())]
    assert shown == pytest.approx(ref, rel=1e-5)
    expect(page.get_by_test_id("design-step").locator(".main-svg").first).to_be_visible()
    page.locator("#f-duration").fill("1")
    page.get_by_role("button", name="Run with this K").click()
    expect(page.locator(".run-panel .badge")).to_have_text("finished", timeout=20_000)
    # the design's run is drawn against its prediction at once, and its step compared with
    # the model's in numbers: those python-control's step_info gives on the recording
    expect(page.get_by_test_id("show-prediction")).to_be_checked()
    steps = page.get_by_test_id("prediction-steps")
    expect(steps.locator("tbody tr")).to_have_count(1, timeout=30_000)
    expect(steps.locator("tbody th")).to_have_text("t = 0 s: 0° → 30°")
    page.wait_for_function(
        """() => document.querySelector('[data-testid=live-plot]').data
          .some(t => t.name.endsWith(', predicted') && t.x.length)"""
    )
    rid = run_id(page)
    rec = httpx.get(f"{server.url}/api/v1/runs/{rid}/data?format=json", timeout=30).json()
    t, theta = np.array(rec["t"]), np.array(rec["data"]["theta"])
    pred = httpx.get(f"{server.url}/api/v1/runs/{rid}/prediction", timeout=60).json()
    model = np.array(next(c["values"] for c in pred["channels"] if c["name"] == "theta"))
    ours = ct.step_info(theta - theta[0], t - t[0])
    theirs = ct.step_info(model - model[0], t[: model.size] - t[0])
    cell = steps.locator('td[data-characteristic="overshoot"]')
    run_os, model_os = (float(v) for v in re.findall(r"(-?[\d.]+) %", cell.inner_text())[:2])
    assert run_os == pytest.approx(ours["Overshoot"], rel=2e-3, abs=0.01)  # (3 digits shown)
    assert model_os == pytest.approx(theirs["Overshoot"], rel=2e-3, abs=0.01)
    rise = steps.locator('td[data-characteristic="rise time"]').inner_text()
    run_rise = float(re.match(r"([\d.]+) s", rise).group(1))  # type: ignore[union-attr]
    assert run_rise == pytest.approx(ours["RiseTime"], rel=5e-3, abs=1.5e-3)
    page.screenshot(path=shots / "design.png", full_page=True)


def test_unknown_pages_and_runs_say_so(page: Page) -> None:
    page.goto("/runs/r-doesnotexist")
    expect(page.locator(".failure")).to_contain_text("unknown run")
    page.goto("/plants/nope")
    expect(page.locator(".failure")).to_contain_text("nope")


def test_reconnects_after_a_network_blip_without_losing_samples(
    browser: Browser, server: Server
) -> None:
    proxy = BlipProxy(server.port)
    context = browser.new_context(
        viewport={"width": 1280, "height": 800}, base_url=proxy.url, accept_downloads=True
    )
    try:
        page = context.new_page()
        page.goto("/plants/flexible_link/analysis")
        page.locator("#f-duration").fill("6")
        page.get_by_role("button", name="Start").click()
        wait_samples(page, 1000)
        assert proxy.blip() >= 1  # the websocket drops; the run goes on being recorded
        expect(page.locator(".run-panel[data-reconnects]")).to_have_count(1, timeout=10_000)
        expect(page.locator(".run-panel .badge")).to_have_text("finished", timeout=30_000)
        rid = run_id(page)
        n = httpx.get(f"{server.url}/api/v1/runs/{rid}").json()["n_samples"]
        assert n == 6000
        wait_samples(page, n)
        got = plot_data(page).splitlines()
        assert len(got) == n + 1
        # every sample, in order, the recording's (held as float32 by the page) in the
        # plot's degrees
        rec = httpx.get(f"{server.url}/api/v1/runs/{rid}/data?format=json&channels=theta").json()
        col = got[0].split(",").index("theta (°)")
        mine = np.array([float(line.split(",")[col]) for line in got[1:]])
        held = np.asarray(rec["data"]["theta"], dtype=np.float32).astype(np.float64)
        np.testing.assert_allclose(mine, held * 180 / np.pi, rtol=1e-12, atol=1e-12)
    finally:
        context.close()
        proxy.close()


@pytest.mark.parametrize("plant", ["double_pendulum", "belt_conveyor", "flexible_link"])
def test_every_plant_runs_its_analysis_in_the_browser(
    page: Page, server: Server, plant: str
) -> None:
    # on one server, one after another: runs of different sizes share the stepper
    page.goto(f"/plants/{plant}/analysis")
    page.locator("#f-duration").fill("1")
    page.get_by_role("button", name="Start").click()
    expect(page.locator(".run-panel .badge")).to_have_text("finished", timeout=20_000)
    info = httpx.get(f"{server.url}/api/v1/runs/{run_id(page)}").json()
    assert info["n_samples"] == info["n_planned"] > 0
    wait_samples(page, info["n_samples"])
    expect(page.locator("[data-testid=bode] .main-svg").first).to_be_visible()


def test_runs_list_filters_by_plant_and_opens_a_run(
    page: Page, server: Server, shots: Path
) -> None:
    for plant in ("belt_conveyor", "flexible_link"):
        r = httpx.post(
            f"{server.url}/api/v1/runs", json={"plant": plant, "duration": 0.5, "pace": "fast"}
        )
        assert r.status_code == 201
    page.goto("/")
    page.get_by_role("link", name="Runs", exact=True).click()
    expect(page).to_have_url(re.compile(r"/runs$"))
    expect(page.locator("table.runs tbody tr").first).to_be_visible()
    page.locator("#plant-filter").select_option("belt_conveyor")
    expect(page).to_have_url(re.compile(r"/runs\?plant=belt_conveyor$"))
    rows = page.locator("table.runs tbody tr")
    # people's names in the table, the ids in its data
    expect(rows.first.locator("td[data-plant]")).to_have_text("Belt conveyor")
    expect(rows.first.locator("td[data-experiment]")).to_have_text("System analysis")
    for cell in rows.locator("td[data-plant]").all():
        assert cell.get_attribute("data-plant") == "belt_conveyor"
        assert cell.inner_text() == "Belt conveyor"
    page.screenshot(path=shots / "runs.png", full_page=True)
    rows.first.get_by_role("link").click()
    expect(page).to_have_url(re.compile(r"/runs/r-[0-9a-f]+$"))
    expect(page.locator(".run-panel .badge")).to_have_text("finished")


def test_the_link_model_reads_the_models_physics_from_an_identification_run(
    page: Page, shots: Path
) -> None:
    """The chapter's experiment in simulation (a ±40° square, the page's PRBS at the
    input), then the link model on both outputs, kept as recorded: the page shows the
    physical ratios, and on the simulated plant they are the model's own."""
    page.goto("/plants/flexible_link/identification")
    expect(page.locator("#signal-kind")).to_have_value("step")  # 0: the old experiment
    page.locator("#signal-kind").select_option("square")
    page.locator("#f-signal-amplitude").fill("40")
    page.locator("#f-signal-period").fill("2")
    page.locator("#f-duration").fill("12")
    page.get_by_role("button", name="Start").click()
    expect(page.locator(".run-panel .badge")).to_have_text("finished", timeout=60_000)
    panel = page.get_by_test_id("ident-run")
    panel.locator("#id-output").select_option("*")
    panel.locator("#id-detrend").select_option("none")
    panel.locator("#id-decimate").fill("1")  # the link model reads every recorded sample
    panel.locator("#id-models").fill("link")
    panel.get_by_role("button", name="Identify").click()
    table = panel.get_by_test_id("link-parameters")
    expect(table).to_contain_text("K_s/J_l", timeout=60_000)
    b = table.locator("tr", has_text="K_s/J_l").locator("td").first.inner_text()
    value = float(b.split("±")[0])
    assert abs(value / 355.31 - 1) < 0.01, b  # the seed's A: −(A[3,1] + A[2,1])
    table.screenshot(path=shots / "ident-link.png")


def test_the_closed_loop_step_is_a_runs_size_and_says_its_peak_input(
    page: Page, server: Server
) -> None:
    """Issue 27: the analysis page's closed-loop step was 1 rad (57°) and asked for about
    20 V without a word. Now it is the runs' default reference (30° on the flexible link),
    and the page states its peak |u| against the actuator's limit, as the API computes it."""
    page.goto("/plants/flexible_link/analysis")
    expect(page.get_by_role("heading", name=re.compile("Closed loop"))).to_have_text(
        "Closed loop (a 30° step of servo angle θ, a run's default)"
    )
    peak = page.get_by_test_id("step-peak-u")
    expect(peak).to_contain_text("Peak |u|")
    step = httpx.post(
        f"{server.url}/api/v1/plants/flexible_link/step",
        json={"controller": {"kind": "predefined"}, "amplitude": np.radians(30)},
    ).json()
    shown = float(re.search(r"Peak \|u\| ([\d.]+) V", peak.inner_text()).group(1))  # type: ignore[union-attr]
    assert shown == pytest.approx(max(abs(v) for v in step["u"]), rel=1e-3)  # (4 digits)
    assert ("saturates" in peak.inner_text()) == (shown > 10)


def test_a_model_without_an_actuator_limit_says_so_where_runs_start(page: Page) -> None:
    page.goto("/plants/double_pendulum/analysis")
    expect(page.get_by_test_id("saturation-off")).to_contain_text("input is not limited")
    expect(page.get_by_test_id("step-peak-u")).to_contain_text("Peak |u|")
    page.goto("/plants/flexible_link/analysis")
    expect(page.get_by_test_id("learn")).to_be_visible()
    expect(page.get_by_test_id("saturation-off")).to_have_count(0)


def test_a_poor_experiment_gets_verdicts_that_name_the_problem_and_the_fix(
    page: Page, server: Server
) -> None:
    """Issue 26's poor experiments in the browser: the link's default run with a PRBS
    of 0.02 V (θ moves by a few encoder counts) is called noisy with by how much to raise
    the excitation, and its model poor against the physics; an open-loop run of the
    integrating link identified with its means removed gets the integrator's verdict
    with the fix (detrend none)."""

    def recorded(body: dict[str, Any]) -> str:
        run = httpx.post(f"{server.url}/api/v1/runs", json=body).json()
        for _ in range(600):
            if httpx.get(f"{server.url}/api/v1/runs/{run['id']}").json()["status"] == "finished":
                return str(run["id"])
            time.sleep(0.1)
        raise AssertionError("the run did not finish")

    small = recorded(identification_run("flexible_link", seed=1, amplitude=0.02))
    page.goto(f"/plants/flexible_link/identification?run={small}")
    panel = page.get_by_test_id("ident-run")
    expect(page.locator(".run-panel .badge")).to_have_text("finished", timeout=60_000)
    panel.locator("#id-models").fill("oe:4,4,1")
    panel.get_by_role("button", name="Identify").click()
    expect(panel.get_by_test_id("ident-models")).to_contain_text("oe 4 4 1", timeout=60_000)
    data = panel.get_by_test_id("data-verdicts")
    expect(data.locator("[data-topic=noise]")).to_contain_text("raise the excitation")
    expect(data.locator("[data-topic=quantisation]")).to_be_visible()
    expect(panel.get_by_test_id("model-level-0")).to_have_text("poor")
    expect(panel.get_by_test_id("model-verdicts-0").locator("[data-topic=physics]")).to_be_visible()

    base = {"plant": "flexible_link", "experiment": "identification", "pace": "fast"}
    open_loop = recorded(
        base
        | {
            "duration": 20,
            "controller": {"kind": "open_loop"},
            "signal": {"kind": "prbs", "amplitude": 1.0, "order": 10, "band": 0.05},
            "seed": 2,
        }
    )
    page.goto(f"/plants/flexible_link/identification?run={open_loop}")
    panel = page.get_by_test_id("ident-run")
    expect(page.locator(".run-panel .badge")).to_have_text("finished", timeout=60_000)
    panel.locator("#id-detrend").select_option("mean")
    panel.locator("#id-models").fill("n4sid:4")
    panel.get_by_role("button", name="Identify").click()
    expect(panel.get_by_test_id("ident-models")).to_contain_text("n4sid 4", timeout=60_000)
    expect(panel.get_by_test_id("model-level-0")).to_have_text("poor")
    expect(panel.get_by_test_id("data-verdicts").locator("[data-topic=feedback]")).to_contain_text(
        "open loop"
    )
    integrator = panel.get_by_test_id("model-verdicts-0").locator("[data-topic=integrator]")
    expect(integrator).to_contain_text("a ramp the plant never made")
    expect(integrator).to_contain_text("detrend 'none'")
