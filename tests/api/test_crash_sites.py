"""Every input that once made the server answer 500 (fuzzing and hand-made attacks on
`elab serve`), sent exactly as found: each gets a 4xx whose error names the field, and the
websocket keeps its connection or closes with a named code, leaking no watcher."""

from __future__ import annotations

import asyncio
import contextlib
import json
from typing import Any

import httpx
import msgpack
import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

from tests.api.server import TLS, Server, Watcher, until

DEEP = "[" * 100_000 + "]" * 100_000
HUGE = "1" + "0" * 5000  # an integer of 5,001 digits (Python's int() stops at 4,300)
DRYER_CSV = "u,y\n" + "\n".join(f"{i % 3},{i % 5}" for i in range(50))


def file_body(text: str, fmt: str = "csv") -> str:
    return json.dumps(
        {"data": {"source": "file", "format": fmt, "text": text, "input": ["u"], "output": ["y"]}}
    )


# (method, path, body, the field the error must name)
CASES: list[tuple[str, str, str | None, str]] = [
    # JSON nested 100,000 deep, and integers beyond 4,300 digits, on every JSON endpoint
    *[
        (m, p, DEEP, "body")
        for m, p in [
            ("POST", "/runs"),
            ("POST", "/ident"),
            ("POST", "/plants/flexible_link/step"),
            ("POST", "/plants/flexible_link/design/lqr"),
            ("POST", "/plants/flexible_link/design/place"),
            ("POST", "/runs/r-000000000000/params"),
        ]
    ],
    ("POST", "/runs", f'{{"plant": "flexible_link", "seed": {HUGE}}}', "body"),
    ("POST", "/runs", f'{{"plant": "flexible_link", "duration": {HUGE}}}', "body"),
    ("POST", "/plants/flexible_link/design/lqr", f'{{"Q": [1, 1, 1, {HUGE}]}}', "body"),
    # sample times that asked for billions of samples, or none at all
    ("POST", "/runs", '{"plant": "flexible_link", "Ts": 1e-17}', "Ts"),
    ("POST", "/runs", '{"plant": "flexible_link", "Ts": 5e-324, "duration": 1}', "Ts"),
    ("POST", "/runs", '{"plant": "flexible_link", "Ts": 0.0001, "duration": 3600}', "duration"),
    # a pole at ±1e308; a PID whose derivative filter underflows or overflows
    (
        "POST",
        "/plants/flexible_link/design/place",
        '{"poles": [{"re": -1e308, "im": 0}, {"re": -2, "im": 0}, {"re": -3, "im": 0},'
        ' {"re": -4, "im": 0}]}',
        "poles",
    ),
    (
        "POST",
        "/plants/flexible_link/design/place",
        '{"poles": [{"re": 1e308, "im": 0}, {"re": -2, "im": 0}, {"re": -3, "im": 0},'
        ' {"re": -4, "im": 0}]}',
        "poles",
    ),
    (
        "POST",
        "/runs",
        '{"plant": "belt_conveyor", "controller": {"kind": "pid", "Kp": 1e-300,'
        ' "Kd": 1e300, "N": 1e-300}}',
        "controller.N",
    ),
    (
        "POST",
        "/runs",
        '{"plant": "belt_conveyor", "controller": {"kind": "pid", "Kp": 1, "Kd": 1, "N": 5e-324}}',
        "controller.N",
    ),
    (
        "POST",
        "/plants/belt_conveyor/step",
        '{"controller": {"kind": "pid", "Kp": 1, "Kd": 1, "N": 5e-324}}',
        "controller.N",
    ),
    # Unicode digits in integer query parameters
    ("GET", "/runs?limit=²", None, "limit"),
    ("GET", "/runs?offset=²", None, "offset"),
    ("GET", "/runs?limit=٣", None, "limit"),
    # malformed identification files
    ("POST", "/ident", file_body("# sample time: abc s\n" + DRYER_CSV), "data"),
    ("POST", "/ident", file_body("u,y\n" + "1" * 131_073 + ",2\n3,4\n5,6\n"), "data line 2"),
    (
        "POST",
        "/ident",
        file_body('{"units": 5, "u": [1, 2, 3], "y": [1, 2, 3]}', "json"),
        "data.units",
    ),
    (
        "POST",
        "/ident",
        file_body('{"Ts": 0.1, "channels": 7, "data": {"u": [1, 2, 3], "y": [1, 2, 3]}}', "json"),
        "data.channels",
    ),
    (
        "POST",
        "/ident",
        file_body(f'{{"Ts": 0.1, "u": [1, 2, 3], "y": [{HUGE}, 2, 3]}}', "json"),
        "data.y",
    ),
    (
        "POST",
        "/ident",
        file_body(f'{{"Ts": {HUGE}, "u": [1, 2, 3], "y": [1, 2, 3]}}', "json"),
        "data.Ts",
    ),
    ("POST", "/ident", file_body(f'{{"Ts": 0.1, "u": {DEEP[:20_000]}, "y": [1]}}', "json"), "data"),
]


@pytest.mark.parametrize(
    ("method", "path", "body", "field"),
    CASES,
    ids=[f"{m} {p} {(b or '')[:40]}" for m, p, b, _ in CASES],
)
def test_each_former_crash_is_a_4xx_naming_the_field(
    server: Server, method: str, path: str, body: str | None, field: str
) -> None:
    r = httpx.request(
        method,
        server.url + "/api/v1" + path,
        content=body,
        headers={"content-type": "application/json"},
        timeout=60,
        verify=TLS,
    )
    assert 400 <= r.status_code < 500, r.text[:300]
    error = r.json()["error"]
    assert error["field"] == field or (r.status_code == 404 and field == "body"), error


def _server_watchers(server: Server) -> int:
    return int(server.status()["watchers"])


def test_websocket_bodies_that_crashed_keep_the_connection(server: Server) -> None:
    with server.client() as c:
        rid = c.post("/runs", json={"plant": "flexible_link", "duration": 30}).json()["id"]

    async def scenario() -> list[dict[str, Any]]:
        w = await Watcher.open(server.ws_url, rid, as_=server)
        for bad in (
            DEEP,
            f'{{"type": "resume_from", "seq": {HUGE}}}',
            b"\x91" * 100_000 + b"\xc0",
            b"",
        ):
            await w.conn.send(bad)
        errors: list[dict[str, Any]] = []
        while len(errors) < 4:
            msg = await w.next()
            if msg["type"] == "error":
                errors.append(msg)
        await w.conn.send(msgpack.packb({"type": "stop"}))  # still listening
        await w.until_status({"stopped"})
        await w.conn.close()
        return errors

    errors = asyncio.run(scenario())
    assert [e["code"] for e in errors] == ["invalid"] * 4


def test_a_bad_from_seq_closes_with_4400_naming_it_and_leaks_no_watcher(server: Server) -> None:
    with server.client() as c:
        rid = c.post("/runs", json={"plant": "belt_conveyor", "duration": 30}).json()["id"]
    before = _server_watchers(server)

    async def close_reason(query: str) -> tuple[int | None, str | None]:
        async with connect(
            f"{server.ws_url}/api/v1/runs/{rid}/stream{query}", subprotocols=["elab.v1"]
        ) as ws:  # type: ignore[list-item]
            with contextlib.suppress(ConnectionClosed):
                await asyncio.wait_for(ws.recv(), 10)
            return ws.close_code, ws.close_reason

    for query in ("?from_seq=²", "?from_seq=-1", "?from_seq=" + "9" * 40):
        code, reason = asyncio.run(close_reason(query))
        assert code == 4400 and reason is not None and reason.startswith("from_seq"), reason
    # none left (an earlier test's watcher of this shared server may still be leaving)
    until(lambda: _server_watchers(server) <= before, 30)
    with server.client() as c:
        c.post(f"/runs/{rid}/stop")
