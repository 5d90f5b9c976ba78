"""A controller of one's own in the browser (issue 14): download a template from the
design page, edit it, upload it, read its report, run it against the predefined
controller, find it among "Your controllers", delete it; refused files say why."""

from __future__ import annotations

import io
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from playwright.sync_api import APIRequestContext, Locator, Page, expect

from tests.api.server import Server, until

NUMBER = r"-?\d+(?:\.\d+)?(?:e-?\d+)?"


def own(page: Page) -> Locator:
    return page.get_by_test_id("own-controller")


def download(page: Page, link: str) -> tuple[str, bytes]:
    """Click a template link in the panel: the file's suggested name and bytes."""
    with page.expect_download() as info:
        own(page).get_by_role("link", name=link).click()
    dl = info.value
    return dl.suggested_filename, Path(dl.path()).read_bytes()


def upload(page: Page, name: str, data: bytes, mime: str = "application/octet-stream") -> None:
    page.locator("#own-file").set_input_files(
        files=[{"name": name, "mimeType": mime, "buffer": data}]
    )


def mine(request: APIRequestContext, plant: str) -> list[dict]:
    """The page's identity's controllers, asked over the API with the page's cookie."""
    got = request.get(f"/api/v1/controllers?plant={plant}")
    assert got.ok, got.text()
    return list(got.json()["controllers"])


def sig3(x: float) -> str:
    """x to 3 significant digits, as the page writes it (27.824 -> 27.8)."""
    return f"{float(f'{x:.3g}'):g}"


def shown_poles(text: str) -> list[tuple[float, float]]:
    """'-83.49 ± 179.2j, -10.45' -> [(-83.49, 179.2), (-10.45, 0)] (|im| of each pair)."""
    out = []
    for item in text.split(", "):
        m = re.fullmatch(rf"({NUMBER})(?: [±+−] ({NUMBER})j)?", item)
        assert m, item
        out.append((float(m[1]), float(m[2] or 0)))
    return out


def test_template_edit_upload_report_run_list_delete(
    page: Page, server: Server, shots: Path
) -> None:
    page.goto("/plants/flexible_link/design")
    expect(own(page).get_by_role("heading", name="Your own controller")).to_be_visible()
    expect(page.get_by_test_id("controller-list")).to_contain_text("None yet")

    # the TOML template: the predefined LQR with comments; the flexible link's K1 20 -> 15
    name, data = download(page, "TOML (with comments)")
    assert name == "flexible_link-controller.toml"
    text = data.decode()
    assert "K = [20, -93.5614, 3.3621, 0.9623]" in text and text.startswith("# E-Lab controller")
    edited = text.replace("K = [20,", "K = [15,", 1).replace('"my controller"', '"softer theta"')
    upload(page, "softer.toml", edited.encode(), "application/toml")

    report = page.get_by_test_id("controller-report")
    expect(report.get_by_role("heading", name="softer theta")).to_be_visible()
    expect(page.get_by_test_id("upload-status")).to_contain_text("stable")
    expect(report.get_by_test_id("controller-law")).to_have_text(
        "K = [15, -93.5614, 3.3621, 0.9623]"
    )
    expect(report.get_by_test_id("verdict")).to_have_text(
        "stable: every closed-loop pole has a negative real part"
    )
    # u(0+) = Kθ·r for state feedback (docs/controllers.md): 15 V/rad · 30° = 7.854 V, within
    # ±10 V (the predefined 20 asks 10.47 V)
    expect(report.get_by_test_id("peak-u")).to_have_text("7.854 V within ±10 V for a step of 30°")
    expect(report).to_contain_text("gain margin ∞")
    expect(report.get_by_test_id("rig-ready")).to_contain_text("ready: nothing keeps it off")
    expect(report.locator(".problems")).to_have_count(0)

    # the poles shown are the report's, each conjugate pair once, to the 4 digits shown
    [stored] = mine(page.request, "flexible_link")
    assert stored["controller"]["K"] == [15, -93.5614, 3.3621, 0.9623]
    poles = stored["report"]["poles"]
    expected = sorted({(round(p["re"], 6), round(abs(p["im"]), 6)) for p in poles})
    got = sorted(shown_poles(report.get_by_test_id("poles").inner_text()))
    assert len(got) == len(expected) == 4  # two pairs, two real poles: six poles
    for (re_s, im_s), (re_e, im_e) in zip(got, expected, strict=True):
        assert re_s == pytest.approx(re_e, rel=1e-3) and im_s == pytest.approx(im_e, rel=1e-3)

    row = page.locator(f"tr[data-controller={stored['id']}]")
    expect(row).to_contain_text("softer theta")
    expect(row).to_contain_text("toml")
    expect(row.locator(".badge")).to_have_text("stable")
    page.screenshot(path=shots / "controller-report.png", full_page=True)

    # run it: the predefined controller's run under the same reference, dotted on one plot
    page.locator("#own-duration").fill("2")
    page.get_by_role("button", name="Run it").click()
    panel = page.locator(".run-panel")
    expect(panel.locator(".run-bar .badge")).to_have_text("finished", timeout=30_000)
    companion = panel.get_by_test_id("companion")
    expect(companion.locator(".badge")).to_have_text("finished", timeout=30_000)
    legend = panel.locator("[data-testid=live-plot] .legend")
    for label in (
        "servo angle θ",
        "servo angle θ, predefined controller",
        "control u, predefined controller",
    ):
        expect(legend).to_contain_text(label)
    # the plot is the largest thing of the comparison (issue 27: the label took the
    # plot's column and the plot the drawing's 220 px one)
    plot = panel.get_by_test_id("live-plot").bounding_box()
    drawing = panel.get_by_test_id("schematic").bounding_box()
    whole = panel.bounding_box()
    assert plot and drawing and whole
    area = plot["width"] * plot["height"]
    assert area > 2 * drawing["width"] * drawing["height"], (plot, drawing)
    assert plot["width"] > 0.6 * whole["width"], (plot, whole)
    page.screenshot(path=shots / "controller-run.png", full_page=True)

    rid = panel.get_attribute("data-run")
    pid = companion.get_attribute("data-companion")
    runs = {r: page.request.get(f"/api/v1/runs/{r}").json() for r in (rid, pid)}
    a, b = runs[rid]["request"], runs[pid]["request"]
    assert a["controller_id"] == stored["id"] and a["controller"]["K"][0] == 15
    assert b["controller"] == {"kind": "predefined"}
    for key in ("signal", "duration", "seed", "pace", "saturate"):
        assert a[key] == b[key], key
    assert a["duration"] == 2 and a["signal"]["amplitude"] == pytest.approx(math.pi / 6)
    # the runs ran their own laws: u(0) = 15·r(0) for the upload, the predefined one saturates
    data = {
        r: page.request.get(f"/api/v1/runs/{r}/data?format=json&channels=u,r").json()["data"]
        for r in (rid, pid)
    }
    assert data[rid]["u"][0] == pytest.approx(15 * data[rid]["r"][0], rel=1e-9)
    assert data[pid]["u"][0] == pytest.approx(10.0)
    # both plotted to the end, sample k over sample k
    ends = page.evaluate(
        """() => document.querySelector('[data-testid=live-plot]').data
             .map(t => [t.name, t.x.length ? t.x[t.x.length - 1] : -1])"""
    )
    assert {n for n, end in ends if end > 1.9} >= {
        "servo angle θ",
        "servo angle θ, predefined controller",
    }

    # delete it from "Your controllers"
    page.once("dialog", lambda d: d.accept())
    row.get_by_role("button", name="Delete controller softer theta").click()
    expect(row).to_have_count(0)
    expect(page.get_by_test_id("upload-status")).to_have_text("Deleted “softer theta”.")
    expect(report).to_have_count(0)
    assert mine(page.request, "flexible_link") == []


def test_refused_files_say_why_and_store_nothing(page: Page) -> None:
    page.goto("/plants/flexible_link/design")
    posts: list[str] = []
    page.on("request", lambda r: posts.append(r.url) if r.method == "POST" else None)
    error = page.get_by_test_id("upload-error")
    # a good file first: its report is on screen until a refused file takes its place
    good = b'version = 1\nplant = "flexible_link"\nname = "kept"\nkind = "pid"\nKp = 10.0\n'
    upload(page, "good.toml", good, "application/toml")
    expect(page.get_by_test_id("controller-report")).to_have_count(1)
    until(lambda: posts)
    posts.clear()

    broken = b'version = 1\nkind = = "pid"\n'
    upload(page, "broken.toml", broken, "application/toml")
    # the server's message, verbatim, with the line and column
    said = page.request.post(
        "/api/v1/controllers",
        data={"plant": "flexible_link", "format": "toml", "content": broken.decode()},
    )
    assert said.status == 422
    message = said.json()["error"]["message"]
    assert "line 2, column 8" in message
    expect(error).to_have_text(f"broken.toml was refused: {message}")
    expect(page.get_by_test_id("controller-report")).to_have_count(0)

    # too large, or not a controller file: refused in the page, nothing sent
    until(lambda: posts)
    sent = len(posts)
    upload(page, "huge.toml", b"#" * (64 * 1024 + 1), "application/toml")
    expect(error).to_have_text(
        "huge.toml was refused: huge.toml is 64.1 KiB: a controller file may be at most "
        "64 KiB. Nothing was sent."
    )
    upload(page, "notes.txt", b"K = 1", "text/plain")
    expect(error).to_contain_text("notes.txt: not a controller file")
    assert len(posts) == sent
    assert [c["name"] for c in mine(page.request, "flexible_link")] == ["kept"]
    expect(page.get_by_test_id("controller-report")).to_have_count(0)  # not the old file's


def test_mat_pid_for_the_belt_conveyor_reports_and_runs_from_the_list(page: Page) -> None:
    page.goto("/plants/belt_conveyor/design")
    buf = io.BytesIO()
    scipy.io.savemat(buf, {"Kp": 12.0, "Ki": 0.49, "Kd": 0.5})
    upload(page, "pid.mat", buf.getvalue())

    report = page.get_by_test_id("controller-report")
    expect(report.get_by_role("heading", name="pid.mat")).to_be_visible()
    expect(report).to_contain_text("MAT file")
    expect(report.get_by_test_id("controller-law")).to_have_text(
        "Kp = 12, Ki = 0.49, Kd = 0.5, N = 10"
    )
    expect(report.get_by_test_id("verdict")).to_contain_text("stable")
    # u(0+) = Kp (1 + N) r with the filtered derivative: 12 · 11 · 0.5 m = 66 V, beyond ±10 V
    peak = report.get_by_test_id("peak-u")
    expect(peak).to_have_text("66 V beyond ±10 V for a step of 500 mm")
    expect(peak).to_have_class("warn")
    expect(report.locator(".warnings")).to_contain_text("saturates")
    [stored] = mine(page.request, "belt_conveyor")
    gm, pm = stored["report"]["gain_margin_db"], stored["report"]["phase_margin_deg"]
    expect(report).to_contain_text(f"gain margin {sig3(gm)} dB, phase margin {sig3(pm)}°")

    # "Run" in the list runs it with the form's reference and duration; the predefined
    # controller's run is paused, resumed and stopped with it
    page.locator("#own-duration").fill("60")
    page.get_by_role("button", name="Run controller pid.mat").click()
    panel = page.locator(".run-panel")
    status = panel.locator(".run-bar .badge")
    companion = panel.get_by_test_id("companion").locator(".badge")
    expect(status).to_have_text("running", timeout=20_000)
    page.wait_for_function(
        "() => Number(document.querySelector('.companion-progress')?.dataset.samples) > 500"
    )
    for button, state in (("Pause", "paused"), ("Resume", "running"), ("Stop", "stopped")):
        panel.get_by_role("button", name=button, exact=True).click()
        expect(status).to_have_text(state)
        expect(companion).to_have_text(state)
    rid = panel.get_attribute("data-run")
    pid = panel.get_by_test_id("companion").get_attribute("data-companion")
    assert (
        page.request.get(f"/api/v1/runs/{rid}").json()["request"]["controller"]
        == (stored["controller"])
    )
    assert page.request.get(f"/api/v1/runs/{pid}").json()["status"] == "stopped"


def test_templates_in_every_format_and_a_dropped_file(page: Page) -> None:
    page.goto("/plants/flexible_link/design")
    predefined = [20, -93.5614, 3.3621, 0.9623]
    _, mat = download(page, "MATLAB .mat")
    np.testing.assert_allclose(scipy.io.loadmat(io.BytesIO(mat))["K"].ravel(), predefined)
    _, npz = download(page, "NumPy .npz")
    with np.load(io.BytesIO(npz), allow_pickle=False) as z:
        np.testing.assert_allclose(z["K"], predefined)
    name, js = download(page, "JSON")
    assert name == "flexible_link-controller.json"
    template = json.loads(js)
    assert template["K"] == predefined

    # dropped on the panel: uploaded like a picked file; dropped beside it: nothing (the
    # browser would open the file and leave the page)
    template["K"][0] = 18
    template["name"] = "dropped"
    drop = """([selector, text]) => {
          const dt = new DataTransfer();
          dt.items.add(new File([text], "dropped.json", { type: "application/json" }));
          const el = document.querySelector(selector);
          const fire = (type) => el.dispatchEvent(
            new DragEvent(type, { dataTransfer: dt, bubbles: true, cancelable: true }));
          const over = !fire("dragover");
          const highlighted = el.classList.contains("dragover");
          return { over, highlighted, dropped: !fire("drop") };
        }"""
    beside = page.evaluate(drop, ["header.page", json.dumps(template)])
    assert beside == {"over": True, "highlighted": False, "dropped": True}  # default prevented
    expect(page.get_by_test_id("upload-status")).to_be_empty()
    on = page.evaluate(drop, ["[data-testid=own-controller]", json.dumps(template)])
    assert on == {"over": True, "highlighted": True, "dropped": True}
    report = page.get_by_test_id("controller-report")
    expect(report.get_by_role("heading", name="dropped")).to_be_visible()
    expect(report.get_by_test_id("controller-law")).to_have_text(
        "K = [18, -93.5614, 3.3621, 0.9623]"
    )
    expect(own(page)).not_to_have_class(re.compile("dragover"))


def test_python_template_edited_uploaded_tried_and_run_with_its_compute_time(
    page: Page, shots: Path
) -> None:
    page.goto("/plants/flexible_link/design")
    name, data = download(page, "Python (.py)")
    assert name == "flexible_link-controller.py"
    text = data.decode()
    assert "class Controller" in text
    assert re.search(r"^K = np\.array\(\[20, ", text, re.MULTILINE), text
    edited = text.replace("K = np.array([20,", "K = np.array([18,", 1)
    upload(page, "softer.py", edited.encode(), "text/x-python")

    # checked by trial runs in the sandbox (a second or two): no poles, no margins
    report = page.get_by_test_id("controller-report")
    expect(report.get_by_role("heading", name="softer.py")).to_be_visible(timeout=60_000)
    expect(page.get_by_test_id("upload-status")).to_contain_text("trial runs ran through")
    expect(report).to_contain_text("Python file")
    expect(report.get_by_test_id("trial")).to_contain_text("a step and a square wave")
    expect(report.get_by_test_id("verdict")).to_contain_text("ran through")
    compute = report.get_by_test_id("compute-time")
    expect(compute).to_contain_text("µs")
    expect(compute).to_contain_text(re.compile(r"Compute time per step: median \S+ µs"))
    expect(report.get_by_test_id("peak-u")).to_contain_text("V")
    expect(report.get_by_test_id("poles")).to_have_count(0)
    expect(report).not_to_contain_text("margin")
    [stored] = mine(page.request, "flexible_link")
    assert stored["format"] == "py" and stored["controller"] is None
    one = page.request.get(f"/api/v1/controllers/{stored['id']}").json()
    assert "K = np.array([18," in one["code"]
    assert stored["report"]["domain"] == "trial" and stored["report"]["compute"]["steps"] > 0
    expect(report.get_by_test_id("controller-code")).to_contain_text("K = np.array([18,")

    # in "Your controllers" as Python, with Run (a Python controller is never swapped
    # into a live run)
    row = page.locator(f"tr[data-controller={stored['id']}]")
    expect(row).to_contain_text("Python (py)")
    expect(row.get_by_role("button", name="Run controller softer.py")).to_be_visible()
    page.screenshot(path=shots / "controller-python-report.png", full_page=True)

    # run it against the predefined controller: once it ended, its compute time per step
    page.locator("#own-duration").fill("2")
    page.get_by_role("button", name="Run it").click()
    panel = page.locator(".run-panel")
    expect(panel.locator(".run-bar .badge")).to_have_text("finished", timeout=60_000)
    expect(panel.get_by_test_id("companion").locator(".badge")).to_have_text(
        "finished", timeout=60_000
    )
    shown = panel.get_by_test_id("run-compute-time")
    expect(shown).to_contain_text("µs", timeout=30_000)
    rid = panel.get_attribute("data-run")
    record = page.request.get(f"/api/v1/runs/{rid}").json()
    assert record["status"] == "finished" and record["error"] is None
    assert record["request"]["controller_id"] == stored["id"]
    times = record["compute"]
    assert times["steps"] > 0
    expect(shown).to_contain_text(f"{times['misses']:,} late of {times['steps']:,} steps")
    expect(panel.locator(":scope > p.error")).to_be_empty()  # the run's own message
    page.screenshot(path=shots / "controller-python-run.png", full_page=True)
