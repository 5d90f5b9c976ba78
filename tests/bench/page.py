"""Issue 28's page benchmark: what the analysis page weighs and how soon it shows a plot.

A real ``elab serve`` and headless Chromium at 1280×800; each load in a fresh browser
context (an empty cache, as a student's first visit). Measured per load:

- the JavaScript the page fetched, as sent (gzip-encoded bytes: ``request.sizes()``'s
  ``responseBodySize``), and all bytes of every response;
- the first plot: ``performance.now()`` (from the navigation's start) when the first
  plotly trace is in the page (a ``MutationObserver`` installed before any script runs).

The peer, in the same browser and the same run: a static page holding only plotly.js's
basic bundle (the one the app ships) drawing one scatter trace of 1,000 points, served by
Python's ``http.server`` on loopback. The page's own work beyond it (its modules, its
requests to the API, the analyses the server computes) is the difference.
"""

from __future__ import annotations

import functools
import http.server
import os
import statistics
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from playwright.sync_api import Browser, Request

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tests.bench.liveplot import app_in_browser  # noqa: E402

PLOTLY = ROOT / "frontend" / "node_modules" / "plotly.js-basic-dist-min" / "plotly-basic.min.js"
PAGE = "/plants/flexible_link/analysis"
REPEAT = 3

# the time of the first plotly trace in the page (ms from the navigation's start)
FIRST_TRACE = """
new MutationObserver((_, observer) => {
  if (document.querySelector('.js-plotly-plot .scatterlayer .trace')) {
    window.benchFirstPlot = performance.now();
    observer.disconnect();
  }
}).observe(document, { childList: true, subtree: true });
"""

PEER_HTML = """<!doctype html><html><head><meta charset="utf-8">
<script src="/plotly-basic.min.js"></script></head><body><div id="p"></div><script>
const x = Array.from({ length: 1000 }, (_, i) => i / 100);
Plotly.react("p", [{ type: "scatter", mode: "lines", x, y: x.map(Math.sin) }], {});
</script></body></html>"""


@dataclass(frozen=True)
class Load:
    first_plot_s: float
    js_bytes: int  # as sent (encoded)
    all_bytes: int


def _load(browser: Browser, url: str) -> Load:
    context = browser.new_context(viewport={"width": 1280, "height": 800})
    sizes: list[tuple[str, int]] = []

    def finished(request: Request) -> None:
        sizes.append((request.resource_type, request.sizes()["responseBodySize"]))

    try:
        context.add_init_script(FIRST_TRACE)
        page = context.new_page()
        page.on("requestfinished", finished)
        page.goto(url)
        page.wait_for_function("() => window.benchFirstPlot !== undefined", timeout=60_000)
        first = float(page.evaluate("window.benchFirstPlot")) / 1000
        page.wait_for_load_state("networkidle")
    finally:
        context.close()
    js = sum(n for kind, n in sizes if kind == "script")
    return Load(first, js, sum(n for _, n in sizes))


@contextmanager
def _peer_site() -> Iterator[str]:
    """The peer page and plotly's basic bundle from ``http.server`` on loopback."""
    with tempfile.TemporaryDirectory() as site:
        Path(site, "index.html").write_text(PEER_HTML, encoding="utf-8")
        Path(site, "plotly-basic.min.js").write_bytes(PLOTLY.read_bytes())
        handler = functools.partial(_Quiet, directory=site)
        httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        thread = threading.Thread(target=httpd.serve_forever, daemon=True)
        thread.start()
        try:
            yield f"http://127.0.0.1:{httpd.server_address[1]}/index.html"
        finally:
            httpd.shutdown()
            httpd.server_close()


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: object) -> None:
        pass


def _spread(xs: list[float], fmt: str) -> str:
    return " / ".join(format(x, fmt) for x in (min(xs), statistics.median(xs), max(xs)))


def bench_page() -> str:
    """The markdown section of docs/benchmarks.md for issue 28's page goals."""
    load0 = os.getloadavg()[0]
    with app_in_browser() as (server, browser), _peer_site() as peer_url:
        _load(browser, server.url + PAGE)  # the server's first analyses: warm
        lab, peer = [], []
        for _ in range(REPEAT):  # interleaved: both see the same load
            lab.append(_load(browser, server.url + PAGE))
            peer.append(_load(browser, peer_url))
    load1 = os.getloadavg()[0]
    lab_first = [x.first_plot_s for x in lab]
    peer_first = [x.first_plot_s for x in peer]
    ratio = statistics.median(lab_first) / statistics.median(peer_first)
    js_kb = statistics.median(x.js_bytes for x in lab) / 1000
    all_kb = statistics.median(x.all_bytes for x in lab) / 1000
    return f"""## The page (issue 28)

The analysis page of the flexible link (`{PAGE}`), a first visit (an empty cache) in
headless Chromium at 1280×800, against a static page of plotly.js's basic bundle drawing
one trace (`tests/bench/page.py`). min / median / max of {REPEAT}, interleaved.

| measure | the analysis page | peer: plotly basic alone | goal |
|---|---|---|---|
| first plot (s from the navigation's start) | {_spread(lab_first, ".2f")} | {_spread(peer_first, ".2f")} | ≤ 0.6 s |
| **ratio of the medians** | **{ratio:.2f}×** | 1 | |
| JavaScript as sent (gzip) | {js_kb:,.0f} KB | {statistics.median(x.js_bytes for x in peer) / 1000:,.0f} KB (not compressed) | ≤ 500 KB |
| every response as sent | {all_kb:,.0f} KB | | |

Load average {load0:.1f} before, {load1:.1f} after.
"""
