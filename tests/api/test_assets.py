"""The app's assets (elab/api/assets.py): the build's gzip to a browser that takes it,
the file itself to one that does not, both cached for a year under their hashed names."""

from __future__ import annotations

import gzip
import re
import socket
import time
from pathlib import Path

import httpx
import pytest

from tests.api.server import TLS, Server, until

ASSETS = Path(__file__).resolve().parents[2] / "backend" / "elab" / "api" / "static" / "assets"


def _plot_bundle() -> Path:
    found = list(ASSETS.glob("plot-*.js")) if ASSETS.is_dir() else []
    if not found:
        pytest.skip("the app is not built (make install builds it)")
    return found[0]


def test_an_asset_is_sent_as_the_builds_gzip_and_cached_under_its_hash(server: Server) -> None:
    plot = _plot_bundle()
    raw = plot.read_bytes()
    url = f"{server.url}/assets/{plot.name}"
    with httpx.Client(verify=TLS, timeout=30) as http:
        # httpx decodes the body; the bytes sent are the build's file, not a new gzip
        r = http.get(url, headers={"accept-encoding": "gzip"})
        assert r.status_code == 200 and r.content == raw
        assert r.headers["content-encoding"] == "gzip"
        assert r.headers["content-type"].startswith("text/javascript")
        assert "immutable" in r.headers["cache-control"] and "Accept-Encoding" in r.headers["vary"]
        assert int(r.headers["content-length"]) == (plot.parent / f"{plot.name}.gz").stat().st_size
        assert int(r.headers["content-length"]) < len(raw) / 2
        # asked again with its tag: 304, nothing sent
        again = http.get(
            url, headers={"accept-encoding": "gzip", "if-none-match": r.headers["etag"]}
        )
        assert again.status_code == 304 and again.content == b""
        assert "immutable" in again.headers["cache-control"]
        # a client that takes no gzip gets the file as it is, one that refuses it by name too
        for refusal in ("identity", "gzip;q=0, identity"):
            plain = http.get(url, headers={"accept-encoding": refusal})
            assert plain.status_code == 200 and plain.content == raw
            assert "content-encoding" not in plain.headers
            assert "immutable" in plain.headers["cache-control"]
        # a JSON answer over the middleware's 4 KiB: gzipped, unless refused by name
        spec = server.url + "/api/v1/openapi.json"
        assert http.get(spec, headers={"accept-encoding": "gzip"}).headers["content-encoding"]
        refused = http.get(spec, headers={"accept-encoding": "gzip;q=0"})
        assert refused.status_code == 200 and "content-encoding" not in refused.headers
        assert refused.json()["openapi"]
        # the page itself is never cached: it names the assets of the current build
        page = http.get(server.url + "/", headers={"accept-encoding": "gzip"})
        assert page.headers["cache-control"] == "no-cache"
        assert re.search(r"/assets/[\w-]+\.js", page.text)


def test_missing_and_escaping_asset_paths_are_404(server: Server) -> None:
    with httpx.Client(verify=TLS, timeout=30) as http:
        for path in ("/assets/nothing.js", "/assets/..%2fapp.py", "/assets/%2e%2e/app.py"):
            r = http.get(server.url + path, headers={"accept-encoding": "gzip"})
            assert r.status_code == 404, path


def test_a_download_is_gzipped_at_the_fast_level_and_reads_back_whole(server: Server) -> None:
    """Responses made at request time are compressed at level 1 (app.GZIP_LEVEL): the gzip
    header's XFL byte is 4 ("fastest"), where starlette's default level 9 writes 2."""
    with server.client() as c:
        run = c.post("/runs", json={"plant": "flexible_link", "pace": "fast", "duration": 5}).json()
        until(lambda: c.get(f"/runs/{run['id']}").json()["finished_at"], 120)
        url = f"/runs/{run['id']}/data?format=csv"
        with c.stream("GET", url, headers={"accept-encoding": "gzip"}) as r:
            assert r.status_code == 200 and r.headers["content-encoding"] == "gzip"
            sent = b"".join(r.iter_raw())
        assert sent[:2] == b"\x1f\x8b" and sent[8] == 4, sent[:10]
        text = gzip.decompress(sent).decode()
        for refusal in ("identity", "gzip;q=0"):
            plain = c.get(url, headers={"accept-encoding": refusal})
            assert "content-encoding" not in plain.headers and plain.text == text
        assert len([line for line in text.splitlines() if not line.startswith("#")]) == 5001


def _rss(pid: int, key: str = "VmRSS") -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) * 1024
    raise KeyError(key)


def test_downloads_whose_clients_stop_reading_hold_a_few_parts_and_delay_nobody(
    server: Server,
) -> None:
    """Two clients ask for a long run's CSV (one gzipped, one plain, 57 MB written) and
    stop reading after the first bytes: the writer waits on the socket, the web process
    grows by a few parts at most (issue 28: ≤ 16 MiB; 32 here, the test's own requests
    included), and everyone else is answered meanwhile."""
    assert server.proc is not None
    pid = server.proc.pid
    with server.client() as c:
        body = {"plant": "flexible_link", "pace": "fast", "duration": 300, "noise": True}
        run = c.post("/runs", json=body).json()
        until(lambda: c.get(f"/runs/{run['id']}").json()["finished_at"], 180)
        Path(f"/proc/{pid}/clear_refs").write_text("5")  # the peak size from here
        before = _rss(pid)
        stuck = []
        for encoding in ("gzip", "identity"):
            s = socket.create_connection(("127.0.0.1", server.port), timeout=30)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
            s.sendall(
                f"GET /api/v1/runs/{run['id']}/data?format=csv HTTP/1.1\r\n"
                f"Host: 127.0.0.1:{server.port}\r\nAccept-Encoding: {encoding}\r\n\r\n".encode()
            )
            assert s.recv(1024).startswith(b"HTTP/1.1 200"), encoding
            stuck.append(s)
        try:
            for _ in range(20):  # the others, while those two wait
                assert c.get("/health").status_code == 200
                assert c.get(f"/runs/{run['id']}").status_code == 200
                time.sleep(0.1)
            grown = _rss(pid, "VmHWM") - before
            assert grown < 32 * 2**20, f"{grown / 2**20:.1f} MiB"
        finally:
            for s in stuck:
                s.close()
        # and the same download, read, is whole
        text = c.get(f"/runs/{run['id']}/data?format=csv").text
        assert len([line for line in text.splitlines() if not line.startswith("#")]) == 300_001


def test_the_api_reference_made_on_first_request_is_one_document(tmp_path: Path) -> None:
    """Start-up does not build the OpenAPI document (issue 28): the first requests for it
    and its page, at once on a fresh server, wait for one build and get the document
    openapi_document() gives."""
    import asyncio

    import elab.api.app  # noqa: F401 (the endpoints register with their modules)
    from elab.api.reference import openapi_document

    srv = Server(tmp_path / "data").start()
    try:

        async def at_once() -> list[httpx.Response]:
            async with httpx.AsyncClient(base_url=srv.url + "/api/v1", timeout=60, verify=TLS) as c:
                paths = ["/openapi.json", "/docs"] * 4
                return await asyncio.gather(*(c.get(p) for p in paths))

        answers = asyncio.run(at_once())
    finally:
        srv.stop()
    assert [r.status_code for r in answers] == [200] * 8
    docs = [r.json() for r in answers[::2]]
    assert all(d == docs[0] for d in docs) and docs[0] == openapi_document()
    assert all("E-Lab API" in r.text for r in answers[1::2])
