"""Real headless Chromium (Debian's package) driven by Playwright against a real
``elab serve`` with a fresh data directory."""

from __future__ import annotations

import functools
import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Browser, Page, expect, sync_playwright

from tests.api.server import Server

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
APP = Path(__file__).resolve().parents[2] / "backend" / "elab" / "api" / "static" / "index.html"
# Waits on the page's state get generous caps (Playwright's default is 5 s): on a busy
# machine a page may take seconds to draw what an idle one draws at once.
WAIT_MS = 30_000
expect.set_options(timeout=WAIT_MS)


#: What the pages ask of the system's motion setting, unless a module sets ``MOTION``:
#: "reduce", so the live views draw 5 times a second instead of 30 (frontend/src/dom.ts,
#: ``frameInterval``). A watched live run cost Chromium's renderer 0.9 of a core at 30 draws
#: a second and 0.3 at 5 (docs/benchmarks.md): Chromium was the suite's largest share of
#: CPU. tests/e2e/test_run_view.py, which checks the schematic and the plot following the
#: stream, runs at full motion ("no-preference").
MOTION = "reduce"


@pytest.fixture(scope="module")
def browser(request: pytest.FixtureRequest) -> Iterator[Browser]:
    """Chromium for one test module. Not for the session: Playwright's sync API keeps an
    event loop running in the main thread while it is open, and a test worker runs unit
    tests that call asyncio.run() after the browser tests. Its contexts ask for the
    module's ``MOTION`` unless they say otherwise."""
    assert Path(CHROMIUM).exists(), "Debian's chromium is needed: make test installs it"
    assert APP.exists(), "the app is not built: make install builds it"
    motion = getattr(request.module, "MOTION", MOTION)
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        b.new_context = functools.partial(b.new_context, reduced_motion=motion)  # type: ignore[method-assign]
        yield b
        b.close()


@pytest.fixture
def page(browser: Browser, server: Server) -> Iterator[Page]:
    context = browser.new_context(
        viewport={"width": 1280, "height": 800}, base_url=server.url, accept_downloads=True
    )
    context.set_default_timeout(WAIT_MS)
    pg = context.new_page()
    errors: list[str] = []
    pg.on("pageerror", lambda e: errors.append(f"{e}\n{e.stack}"))
    yield pg
    context.close()
    assert not errors, f"errors in the page: {errors}"


@pytest.fixture(scope="session")
def shots(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where screenshots go: $ELAB_SCREENSHOTS (make screenshots: docs/screenshots)."""
    where = os.environ.get("ELAB_SCREENSHOTS")
    path = Path(where) if where else tmp_path_factory.mktemp("screenshots")
    path.mkdir(parents=True, exist_ok=True)
    return path
