"""Issue 4's benchmark: the live plot of a real-time run in headless Chromium, and issue
15's animated schematic beside it.

A real ``elab serve`` runs the flexible link (4 channels: r, theta, alpha, u at Ts = 1 ms)
from the analysis page; once the plot's 10 s window is full, it is watched for 10 s:
draws per second (``LivePlot`` emits ``elab:draw`` on its div when a draw is on screen, the
schematic ``elab:schematic``), main-thread busy fraction (Chrome DevTools Protocol
``Performance.getMetrics``: ΔTaskDuration / Δwall) and points in view. Peers, in further
runs of the same browser: the plot alone (the schematic taken out of the page), and the
plot drawing every sample (``window.elab.plotSettings.decimate = false``).
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from playwright.sync_api import Browser, Page, sync_playwright

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tests.api.server import Server  # noqa: E402

CHROMIUM = "/usr/bin/chromium"
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
APP = ROOT / "backend" / "elab" / "api" / "static" / "index.html"
WINDOW_SAMPLES = 10_000  # the 10 s window at Ts = 1 ms
SECONDS = 10  # measured, in 1 s buckets
DURATION = 30.0  # of each run (s): the window fills, then the measurement, with margin

# record the time of every draw of the live plot and of the schematic (page clock, ms)
LISTEN = (
    "(div) => { window.benchDraws = []; window.benchSchematic = [];"
    " div.addEventListener('elab:draw', () => window.benchDraws.push(performance.now()));"
    " document.querySelector('[data-testid=schematic]')?.addEventListener('elab:schematic',"
    " () => window.benchSchematic.push(performance.now()));"
    " return performance.now(); }"
)
POINTS = "(div) => div.data.reduce((n, trace) => n + trace.x.length, 0)"


@dataclass(frozen=True)
class PlotFigures:
    fps: float  # median over 1 s buckets
    busy: float  # fraction of wall time the renderer's main thread ran tasks
    points: int  # in view at the end, summed over the traces
    schematic_fps: float  # the animated schematic's draws, median over 1 s buckets


def _task_seconds(metrics: dict[str, list[dict[str, float]]]) -> tuple[float, float]:
    m = {x["name"]: x["value"] for x in metrics["metrics"]}
    return m["TaskDuration"], m["Timestamp"]


def _per_second(times: list[float], t0: float) -> float:
    buckets = [0] * SECONDS
    for t in times:
        if (i := int((t - t0) / 1000)) < SECONDS:
            buckets[i] += 1
    return statistics.median(buckets)


def _measure(page: Page, base_url: str, decimate: bool, schematic: bool = True) -> PlotFigures:
    page.goto(base_url + "/plants/flexible_link/analysis")
    page.wait_for_function("() => window.elab.plotSettings !== undefined")  # the view loads lazily
    page.evaluate(f"window.elab.plotSettings.decimate = {str(decimate).lower()}")
    page.locator("#f-duration").fill(str(DURATION))
    page.get_by_role("button", name="Start").click()
    page.wait_for_function(
        "(n) => Number(document.querySelector('.run-panel .progress')?.dataset.samples) >= n",
        arg=WINDOW_SAMPLES,
        polling=250,
        timeout=60_000,
    )
    plot = page.locator(".run-panel [data-testid=live-plot]")
    if not schematic:  # it still computes each frame, but is neither laid out nor painted
        page.evaluate("document.querySelector('[data-testid=schematic]').remove()")
    cdp = page.context.new_cdp_session(page)
    cdp.send("Performance.enable")
    t0 = plot.evaluate(LISTEN)
    task0, wall0 = _task_seconds(cdp.send("Performance.getMetrics"))
    page.wait_for_timeout(SECONDS * 1000)
    task1, wall1 = _task_seconds(cdp.send("Performance.getMetrics"))
    return PlotFigures(
        _per_second(page.evaluate("window.benchDraws"), t0),
        (task1 - task0) / (wall1 - wall0),
        plot.evaluate(POINTS),
        _per_second(page.evaluate("window.benchSchematic"), t0),
    )


def _run(browser: Browser, base_url: str, decimate: bool, schematic: bool = True) -> PlotFigures:
    context = browser.new_context(viewport={"width": 1280, "height": 800})
    errors: list[str] = []
    try:
        page = context.new_page()
        page.on("pageerror", lambda e: errors.append(str(e)))
        figures = _measure(page, base_url, decimate, schematic)
    finally:
        context.close()
    if errors:
        raise RuntimeError(f"errors in the page: {errors}")
    return figures


@contextmanager
def app_in_browser() -> Iterator[tuple[Server, Browser]]:
    """A fresh ``elab serve`` (its own data directory) and headless Chromium, for the
    browser benchmarks (this one and tests/bench/page.py); both stopped after."""
    if not APP.exists():
        raise RuntimeError(f"the app is not built ({APP} is missing): make install builds it")
    with tempfile.TemporaryDirectory() as data:
        server = Server(Path(data)).start()
        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
                try:
                    yield server, browser
                finally:
                    browser.close()
        finally:
            server.stop()


def bench_live_plot() -> str:
    """The markdown section of docs/benchmarks.md for issue 4's live plot goal."""
    load0 = os.getloadavg()[0]
    with app_in_browser() as (server, browser):
        dec = _run(browser, server.url, decimate=True)
        alone = _run(browser, server.url, decimate=True, schematic=False)
        raw = _run(browser, server.url, decimate=False)
    load1 = os.getloadavg()[0]
    ms = [f.busy * 1000 / f.fps if f.fps else float("inf") for f in (dec, raw)]
    return f"""### Live plot in the browser (issue 4)

The flexible link's 4 channels (r, θ, α, u) at 1 kHz, live from a real-time run over the
websocket, in the plot's 10 s window, in headless Chromium with software rendering
(`--disable-gpu`), viewport 1280×800, on {os.cpu_count()} shared cores (load average
{load0:.1f} before, {load1:.1f} after). Measured for {SECONDS} s once the window is full;
frames per second is the median over 1 s buckets of the plot's draws, main-thread busy is
Chrome's `TaskDuration` over wall time. The plot draws at most every 25 ms (30 frames per
second at 60 Hz), and the time axis steps every tenth of the window; between steps a draw
only replaces the traces (`Plotly.animate` without a full replot). Peer: the same plot
drawing every sample (`window.elab.plotSettings.decimate = false`), measured in the same
way in a second run.

| figure | value | goal |
|---|---|---|
| frames per second, decimated (min/max per 2-pixel column) | {dec.fps:.0f} | ≥ 30 |
| main thread busy, decimated | {dec.busy * 100:.0f} % | ≤ 50 % |
| points in view, decimated | {dec.points:,} | |
| frames per second, every sample drawn (peer) | {raw.fps:.0f} | |
| main thread busy, every sample drawn (peer) | {raw.busy * 100:.0f} % | |
| points in view, every sample drawn (peer) | {raw.points:,} | |
| main-thread time per frame, decimated | {ms[0]:.1f} ms | |
| main-thread time per frame, every sample drawn (peer) | {ms[1]:.1f} ms | |
| **ratio peer / decimated, time per frame** | **{ms[1] / ms[0]:.1f}×** | |

### The animated schematic beside the plot (issue 15)

The same decimated run with the plant's schematic beside the plot (an SVG: the arm turned
by θ, the link bent by α, the readout of the sample drawn), drawn from the newest sample at
most once per animation frame; peer: the plot alone, the schematic taken out of the page in
a further run.

| figure | value | goal |
|---|---|---|
| schematic frames per second | {dec.schematic_fps:.0f} | ≥ 30 |
| plot frames per second, beside it | {dec.fps:.0f} | ≥ 30 |
| main thread busy, plot and schematic | {dec.busy * 100:.0f} % | ≤ 60 % |
| main thread busy, plot alone (peer) | {alone.busy * 100:.0f} % | |
| plot frames per second, alone (peer) | {alone.fps:.0f} | |
"""


if __name__ == "__main__":
    print(bench_live_plot())
