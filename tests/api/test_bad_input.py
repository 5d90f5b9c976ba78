"""Bad input gets a clear error naming the field — never a 500, a hang or lost data."""

from __future__ import annotations

import asyncio
import json
import socket
import struct
from pathlib import Path
from typing import Any

import msgpack
import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

from tests.api.server import Server, Watcher


def _post(server: Server, path: str, body: Any = None, raw: bytes | None = None) -> Any:
    with server.client() as c:
        if raw is not None:
            return c.post(path, content=raw, headers={"content-type": "application/json"})
        return c.post(path, json=body)


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"plant": "flexible_link", "duration": 0}, "duration"),
        ({"plant": "flexible_link", "duration": -5}, "duration"),
        ({"plant": "flexible_link", "duration": 1e9}, "duration"),
        ({"plant": "flexible_link", "duration": "long"}, "duration"),
        (
            {"plant": "flexible_link", "controller": {"kind": "state_feedback", "K": [1, 2]}},
            "controller.K",
        ),
        ({"plant": "flexible_link", "controller": {"kind": "pid"}}, "controller.pid.Kp"),
        ({"plant": "flexible_link", "controller": {"kind": "magic"}}, "controller"),
        (
            {"plant": "flexible_link", "signal": {"kind": "square", "amplitude": 1, "period": 0}},
            "signal.square.period",
        ),
        (
            {"plant": "flexible_link", "signal": {"kind": "prbs", "amplitude": 1, "order": 99}},
            "signal.prbs.order",
        ),
        ({"plant": "flexible_link", "Ts": 0.05}, "Ts"),
        ({"plant": "flexible_link", "pace": "warp"}, "pace"),
        ({"plant": "flexible_link", "colour": "red"}, "colour"),
        ({"plant": "double_pendulum", "x0": [0, 0.5, 3.14, 0, 0, 0]}, "x0[1] (beta1)"),
        ({"plant": "flexible_link", "mode": "rig"}, "mode"),
        ({}, "plant"),
    ],
)
def test_invalid_run_is_422_naming_the_field(
    server: Server, body: dict[str, Any], field: str
) -> None:
    r = _post(server, "/runs", body)
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert err["code"] == "invalid" and err["field"] == field, err


@pytest.mark.parametrize(
    "raw",
    [
        b'{"plant": "flexible_link", "duration": NaN}',
        b'{"plant": "flexible_link", "duration": Infinity}',
        b"not json",
        b"[1, 2]",
        b"",
    ],
)
def test_non_finite_or_malformed_json_is_422(server: Server, raw: bytes) -> None:
    r = _post(server, "/runs", raw=raw)
    assert r.status_code == 422, r.text
    assert r.json()["error"]["field"] in ("duration", "body")


def test_oversized_body_is_413(server: Server) -> None:
    body = {"plant": "flexible_link", "signal": {"kind": "samples", "values": [0.0] * 400_000}}
    r = _post(server, "/runs", raw=json.dumps(body).encode())
    assert r.status_code == 413 and r.json()["error"]["code"] == "too_large"


def test_unknown_ids_are_404(server: Server) -> None:
    with server.client() as c:
        assert c.get("/runs/r-nope").status_code == 404
        assert c.get("/plants/crane").status_code == 404
        assert c.post("/runs", json={"plant": "crane"}).status_code == 404
        assert c.get("/runs/r-nope/data").status_code == 404
        assert c.post("/runs/r-nope/stop").status_code == 404
        assert c.get("/nowhere").json()["error"]["code"] == "not_found"


def test_a_browser_at_an_unknown_address_gets_the_app_with_404(server: Server) -> None:
    """Issue 15: unknown URLs showed raw JSON; a browser (Accept: text/html) now gets the
    app, whose router says "Page not found", with the 404 status. API paths and other
    clients keep the JSON error."""
    import httpx

    from elab.api.app import STATIC

    html = {"accept": "text/html,application/xhtml+xml"}
    r = httpx.get(server.url + "/no/such/page", headers=html, timeout=30)
    assert r.status_code == 404
    if not (STATIC / "index.html").is_file():
        pytest.skip("the app is not built (make build): only the JSON error is there")
    assert r.headers["content-type"].startswith("text/html") and "<script" in r.text
    api = httpx.get(server.url + "/api/v1/no-such-thing", headers=html, timeout=30)
    assert api.status_code == 404 and api.json()["error"]["code"] == "not_found"
    plain = httpx.get(server.url + "/no/such/page", timeout=30)
    assert plain.status_code == 404 and plain.json()["error"]["code"] == "not_found"


def test_illegal_transitions_are_409(server: Server) -> None:
    with server.client() as c:
        rid = c.post("/runs", json={"plant": "belt_conveyor", "duration": 30}).json()["id"]
        assert c.post(f"/runs/{rid}/resume").status_code == 409  # running, not paused
        assert c.post(f"/runs/{rid}/pause").json()["status"] == "paused"
        assert c.post(f"/runs/{rid}/pause").status_code == 409
        assert c.post(f"/runs/{rid}/resume").json()["status"] == "running"
        assert c.post(f"/runs/{rid}/stop").json()["status"] == "stopped"
        r = c.post(f"/runs/{rid}/params", json={"controller": {"kind": "pid", "Kp": 2}})
        assert r.status_code == 409 and "stopped" in r.json()["error"]["message"]


def test_bad_query_parameters_are_422(server: Server) -> None:
    with server.client() as c:
        rid = c.post(
            "/runs", json={"plant": "belt_conveyor", "duration": 0.2, "pace": "fast"}
        ).json()["id"]
        for params, field in [
            ({"format": "xls"}, "format"),
            ({"channels": "speed"}, "channels"),
            ({"t_from": "nan"}, "t_from"),
            ({"t_from": 2, "t_to": 1}, "t_from"),
        ]:
            r = c.get(f"/runs/{rid}/data", params=params)
            assert r.status_code == 422 and r.json()["error"]["field"] == field, r.text
        assert c.get("/runs", params={"limit": 0}).json()["error"]["field"] == "limit"
        r = c.get("/plants/flexible_link/bode", params={"output": "alpha2"})  # not this plant's
        assert r.status_code == 404 and "theta, alpha" in r.json()["error"]["message"]
        r = c.get("/runs", params={"limit": ["10", "20"]})  # repeated: refused, not cut to one
        assert r.status_code == 422 and r.json()["error"]["field"] == "limit"


def test_design_errors_are_422(server: Server) -> None:
    with server.client() as c:
        for body, field in [
            ({"Q": [1, 1, 1]}, "Q"),
            ({"Q": [1, 1, 1, 1], "R": 0}, "R"),
            ({"Q": [1, 1, -1, 1]}, "Q"),
        ]:
            r = c.post("/plants/flexible_link/design/lqr", json=body)
            assert r.status_code == 422 and r.json()["error"]["field"] == field, r.text
        r = c.post("/plants/flexible_link/design/place", json={"poles": [{"re": -1, "im": 0}]})
        assert r.status_code == 422 and r.json()["error"]["field"] == "poles"


def test_too_many_live_runs_is_429(tmp_path: Path) -> None:
    srv = Server(tmp_path / "data", ELAB_MAX_LIVE_RUNS="2").start()
    try:
        with srv.client() as c:
            for _ in range(2):
                assert c.post("/runs", json={"plant": "belt_conveyor"}).status_code == 201
            r = c.post("/runs", json={"plant": "belt_conveyor"})
            assert r.status_code == 429 and "ELAB_MAX_LIVE_RUNS" in r.json()["error"]["message"]
    finally:
        srv.stop()


def test_websocket_errors_keep_the_connection(server: Server) -> None:
    with server.client() as c:
        rid = c.post("/runs", json={"plant": "flexible_link", "duration": 3}).json()["id"]

    async def scenario() -> list[dict[str, Any]]:
        w = await Watcher.open(server.ws_url, rid, as_=c)  # its owner
        for bad in (
            b"\xc1",
            msgpack.packb({"type": "fly"}),
            msgpack.packb({"type": "resume_from", "seq": -1}),
            msgpack.packb(
                {"type": "set_params", "controller": {"kind": "state_feedback", "K": [1]}}
            ),
        ):
            await w.conn.send(bad)
        errors: list[dict[str, Any]] = []
        while len(errors) < 4:
            msg = await w.next()
            if msg["type"] == "error":
                errors.append(msg)
        await w.conn.send(msgpack.packb({"type": "stop"}))
        await w.until_status({"stopped"})
        await w.conn.close()
        return errors

    errors = asyncio.run(scenario())
    # the unknown type is refused as a whole message; the others name their field
    assert [e["field"] for e in errors[1:]] == ["body", "resume_from.seq", "controller.K"], errors
    assert errors[0]["code"] == "invalid"


def test_websocket_unknown_run_and_missing_subprotocol(server: Server) -> None:
    async def close_code(url: str, **kw: Any) -> int | None:
        async with connect(url, **kw) as conn:
            try:
                await conn.recv()
            except ConnectionClosed as exc:
                return exc.rcvd.code if exc.rcvd else None
        return None

    base = server.ws_url + "/api/v1/runs/"
    assert asyncio.run(close_code(base + "r-nope/stream", subprotocols=["elab.v1"])) == 4404
    with server.client() as c:
        rid = c.post("/runs", json={"plant": "belt_conveyor", "duration": 1}).json()["id"]
    assert asyncio.run(close_code(base + rid + "/stream")) == 4400


def test_a_vanishing_watcher_does_not_disturb_the_run(server: Server) -> None:
    with server.client() as c:
        rid = c.post("/runs", json={"plant": "flexible_link", "duration": 2}).json()["id"]

    async def vanish() -> None:
        w = await Watcher.open(server.ws_url, rid)
        await w.next()
        sock = w.conn.transport.get_extra_info("socket")
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        w.conn.transport.abort()  # TCP reset, no close handshake
        await asyncio.sleep(0.1)  # let the aborted transport release its socket

    asyncio.run(vanish())
    with server.client() as c:
        for _ in range(100):
            info = c.get(f"/runs/{rid}").json()
            if info["status"] != "running":
                break
            asyncio.run(asyncio.sleep(0.1))
        assert info["status"] == "finished" and info["n_samples"] == 2000
