"""A page on another origin, open in the same browser as the lab, tries to start and stop
runs the way any web page can without asking: ``fetch`` in no-cors mode with a
``text/plain`` body (the browser sends the lab's cookies along: same site, other port),
a form post, and a websocket. Nothing happens."""

from __future__ import annotations

import functools
import threading
from collections.abc import Iterator
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import httpx
import pytest
from playwright.sync_api import Page

from tests.api.server import Server, free_port

EVIL = """<!doctype html><meta charset=utf-8><title>cute cats</title>
<form id=f method=post enctype=text/plain></form>
<script>
const q = new URLSearchParams(location.search);
const lab = q.get("lab"), run = q.get("run");
const report = {};
async function attack() {
  const body = JSON.stringify({plant: "flexible_link", duration: 5});
  const form = new FormData();  // a controller file as a form: multipart, no preflight
  form.append("plant", "flexible_link");
  form.append("file", new Blob(['version = 1\\nkind = "open_loop"\\n']), "evil.toml");
  for (const [name, url, init] of [
    ["upload", lab + "/api/v1/controllers", {body: form}],
    ["start", lab + "/api/v1/runs", {body, headers: {"content-type": "text/plain"}}],
    ["stop", lab + "/api/v1/runs/" + run + "/stop", {}],
    ["pause", lab + "/api/v1/runs/" + run + "/pause", {body: "{}"}],
  ]) {
    try {
      await fetch(url, {method: "POST", mode: "no-cors", credentials: "include", ...init});
      report[name] = "sent";
    } catch (e) { report[name] = "failed: " + e; }
  }
  report.ws = await new Promise((resolve) => {
    const ws = new WebSocket(lab.replace("http", "ws") + "/api/v1/runs/" + run + "/stream",
                             "elab.v1");
    ws.onopen = () => { ws.send(JSON.stringify({type: "stop"})); resolve("open"); };
    ws.onerror = () => resolve("refused");
  });
  window.report = report;
}
attack();
</script>"""


@pytest.fixture
def evil_site(tmp_path: Path) -> Iterator[str]:
    (tmp_path / "cats.html").write_text(EVIL)
    handler = functools.partial(SimpleHTTPRequestHandler, directory=str(tmp_path))
    httpd = ThreadingHTTPServer(("127.0.0.1", free_port()), handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}/cats.html"
    httpd.shutdown()
    httpd.server_close()


def test_a_page_on_another_origin_cannot_start_or_stop_runs(
    page: Page, server: Server, evil_site: str
) -> None:
    page.goto("/")
    victim = page.evaluate(
        """async () => (await (await fetch("/api/v1/runs", {method: "POST",
             headers: {"content-type": "application/json"},
             body: JSON.stringify({plant: "belt_conveyor", duration: 600})})).json()).id"""
    )
    with httpx.Client(base_url=server.url + "/api/v1") as anyone:
        before = anyone.get("/runs").json()["total"]

        page.goto(f"{evil_site}?lab={server.url}&run={victim}")
        page.wait_for_function("window.report !== undefined", timeout=30_000)
        report = page.evaluate("window.report")
        assert report["ws"] == "refused", report  # the upgrade got 403
        assert report["start"] == "sent" and report["stop"] == "sent", report  # sent, and...
        # a form posted to the lab (a navigation: the page ends up on the lab's answer)
        with page.expect_navigation():
            page.evaluate(
                """(url) => { const f = document.getElementById("f"); f.action = url;
                   const i = document.createElement("input");
                   i.name = '{"plant":"flexible_link","x":"'; i.value = '"}';
                   f.append(i); f.submit(); }""",
                f"{server.url}/api/v1/runs",
            )
        assert "may not use this lab" in page.content()
        run = anyone.get(f"/runs/{victim}").json()
        assert run["status"] == "running", run  # ...refused: the run goes on
        assert anyone.get("/runs").json()["total"] == before  # and nothing was started

    # the lab's own page, in the same browser, still controls the run; the form upload
    # from the other site left nothing in the browser's controllers
    page.goto(f"/runs/{victim}")
    assert report["upload"] == "sent", report
    kept = page.evaluate(
        """async () => (await (await fetch("/api/v1/controllers")).json()).controllers"""
    )
    assert kept == [], kept
    stopped = page.evaluate(
        f"""async () => (await (await fetch("/api/v1/runs/{victim}/stop",
             {{method: "POST"}})).json()).status"""
    )
    assert stopped == "stopped"
