"""Who may do what, against a real server: owners, strangers, instructors and API tokens
over REST and the websocket; private runs; runs nobody watches; per-identity quotas;
requests from other sites and hosts. (The browser's side: tests/e2e/test_access_ui.py
and tests/e2e/test_cross_site.py.)"""

from __future__ import annotations

import asyncio
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import msgpack
import numpy as np
import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidStatus

from elab.api.auth import hash_password
from tests.api.server import TLS, Server, Watcher, until

PASSWORD = "correct horse battery"
LONG = {"plant": "belt_conveyor", "duration": 600}


def instructors_file(directory: Path) -> Path:
    path = directory / "instructors"
    path.write_text(f"# instructor accounts\nprof:{hash_password(PASSWORD)}\n")
    return path


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    data = tmp_path_factory.mktemp("data")
    srv = Server(
        data,
        ELAB_INSTRUCTORS=str(instructors_file(data.parent)),
        ELAB_MAX_LIVE_PER_IDENTITY="3",
        ELAB_OWNER_GRACE="1.5",
        ELAB_OWNER_GONE="4",
    ).start()
    yield srv
    srv.stop()


def instructor(server: Server) -> httpx.Client:
    """A client signed in as the instructor (not yet opened: use it in ``with``)."""
    r = httpx.post(
        server.url + "/api/v1/session", json={"name": "prof", "password": PASSWORD}, verify=TLS
    )
    assert r.status_code == 200 and r.json()["role"] == "instructor", r.text
    return httpx.Client(base_url=server.url + "/api/v1", timeout=30, cookies=r.cookies, verify=TLS)


def start(c: httpx.Client, **extra: Any) -> dict[str, Any]:
    r = c.post("/runs", json={**LONG, **extra})
    assert r.status_code == 201, r.text
    return r.json()  # type: ignore[no-any-return]


def test_a_stranger_can_watch_but_not_control_and_the_run_goes_on(server: Server) -> None:
    with server.client() as owner, server.stranger() as other:
        run = start(owner)
        rid = run["id"]
        assert (run["mine"], run["can_control"]) == (True, True)
        seen = other.get(f"/runs/{rid}").json()
        assert (seen["mine"], seen["can_control"]) == (False, False)
        assert seen["owner"] == owner.get("/me").json()["name"]
        for action in ("pause", "resume", "stop"):
            r = other.post(f"/runs/{rid}/{action}")
            assert r.status_code == 403, r.text
            assert "only its owner or an instructor" in r.json()["error"]["message"]
        r = other.post(f"/runs/{rid}/params", json={"signal": {"kind": "step", "amplitude": 0.1}})
        assert r.status_code == 403
        assert other.delete(f"/runs/{rid}").status_code == 403
        assert other.get(f"/runs/{rid}/data").status_code == 200  # anyone may download

        async def over_the_websocket() -> list[dict[str, Any]]:
            w = await Watcher.open(server.ws_url, rid, as_=other)
            assert w.hello["run"]["can_control"] is False
            for msg in ({"type": "stop"}, {"type": "pause"}):
                await w.conn.send(msgpack.packb(msg))
            errors = []
            while len(errors) < 2:
                m = await w.next()
                assert m["type"] != "status", m  # nothing changed
                if m["type"] == "error":
                    errors.append(m)
            await w.conn.close()
            return errors

        errors = asyncio.run(over_the_websocket())
        assert [e["code"] for e in errors] == ["forbidden", "forbidden"]
        after = owner.get(f"/runs/{rid}").json()
        assert after["status"] == "running" and after["param_changes"] == []
        r = owner.post(f"/runs/{rid}/stop")
        assert r.status_code == 200 and r.json()["error"] == "stopped by its owner"


def test_an_instructor_may_control_any_run_and_pin_the_class_demo(server: Server) -> None:
    with server.stranger() as student, instructor(server) as prof:
        rid = start(student)["id"]
        assert student.put("/demo", json={"run_id": rid}).status_code == 403
        seen = prof.get(f"/runs/{rid}").json()
        assert (seen["mine"], seen["can_control"]) == (False, True)
        assert prof.post(f"/runs/{rid}/pause").json()["status"] == "paused"
        pinned = prof.put("/demo", json={"run_id": rid}).json()
        assert pinned["run"]["id"] == rid and pinned["pinned_by"] == "prof (instructor)"
        assert student.get("/demo").json()["run"]["id"] == rid  # everyone sees the demo
        live = prof.get("/runs", params={"live": "true"}).json()
        assert rid in [r["id"] for r in live["runs"]]
        r = prof.post(f"/runs/{rid}/stop")
        assert r.json()["error"] == "stopped by prof (instructor)"
        until(lambda: student.delete(f"/runs/{rid}").status_code == 204, 10)
        assert student.get("/demo").json()["run"] is None  # a deleted run is no demo
        assert prof.delete("/demo").status_code == 204
        assert student.delete("/demo").status_code == 403


def test_a_private_run_is_invisible_to_others_but_not_to_instructors(server: Server) -> None:
    with server.client() as owner, server.stranger() as other, instructor(server) as prof:
        rid = start(owner, private=True)["id"]
        assert other.get(f"/runs/{rid}").status_code == 404
        assert other.get(f"/runs/{rid}/data").status_code == 404
        assert rid not in [r["id"] for r in other.get("/runs").json()["runs"]]
        assert rid not in [r["id"] for r in other.get("/runs?live=true").json()["runs"]]
        assert rid in [r["id"] for r in owner.get("/runs?owner=me").json()["runs"]]
        assert prof.get(f"/runs/{rid}").json()["private"] is True

        async def stranger_stream() -> int | None:
            w = await connect(
                f"{server.ws_url}/api/v1/runs/{rid}/stream",
                subprotocols=["elab.v1"],  # type: ignore[list-item]
            )
            try:
                await w.recv()
            except Exception as exc:  # closed: not found
                return getattr(getattr(exc, "rcvd", None), "code", None)
            return None

        assert asyncio.run(stranger_stream()) == 4404
        owner.post(f"/runs/{rid}/stop")


def test_my_runs_lists_only_mine_and_a_deleted_run_is_gone(server: Server) -> None:
    with server.stranger() as me, server.stranger() as other:
        mine = start(me, pace="fast", duration=1)["id"]
        start(other, pace="fast", duration=1)
        listed = me.get("/runs", params={"owner": "me"}).json()
        assert [r["id"] for r in listed["runs"]] == [mine] and listed["total"] == 1
        until(lambda: me.get(f"/runs/{mine}").json()["status"] == "finished", 30)
        assert me.delete(f"/runs/{mine}").status_code == 204
        assert me.get(f"/runs/{mine}").status_code == 404
        assert me.get(f"/runs/{mine}/data").status_code == 404
        assert me.get("/runs", params={"owner": "me"}).json()["total"] == 0
        assert me.delete(f"/runs/{mine}").status_code == 404


def test_a_live_run_cannot_be_deleted(server: Server) -> None:
    with server.stranger() as me:
        rid = start(me)["id"]
        r = me.delete(f"/runs/{rid}")
        assert r.status_code == 409 and "stop it before deleting" in r.json()["error"]["message"]
        me.post(f"/runs/{rid}/stop")


def test_a_run_whose_owner_left_pauses_then_stops_with_the_reason_recorded(
    server: Server,
) -> None:
    with server.stranger() as owner:
        rid = start(owner)["id"]

        async def watch_then_leave() -> dict[str, Any]:
            # a stranger watching does not keep it going
            spectator = await Watcher.open(server.ws_url, rid)
            w = await Watcher.open(server.ws_url, rid, as_=owner)
            # watched by its owner, it runs past the grace period
            await asyncio.sleep(2.5)
            assert owner.get(f"/runs/{rid}").json()["status"] == "running"
            await w.conn.close()
            paused = await spectator.until_status({"paused"}, timeout=30)
            stopped = await spectator.until_status({"stopped"}, timeout=30)
            await spectator.conn.close()
            return {"paused": paused, "stopped": stopped}

        seen = asyncio.run(watch_then_leave())
        assert "no connection to it for 1.5 s" in seen["paused"]["error"]
        assert "stops 2.5 s later" in seen["paused"]["error"]
        assert seen["stopped"]["error"].startswith("stopped: its owner had no connection")
        run = until(lambda: (r := owner.get(f"/runs/{rid}").json())["finished_at"] and r, 10)
        assert run["status"] == "stopped" and "ELAB_OWNER_GONE" in run["error"]
        head = owner.get(f"/runs/{rid}/data").text.split("\nt,", 1)[0]
        assert "# status: stopped" in head
        assert "# reason: stopped: its owner had no connection to it for 4 s" in head


def test_an_owner_polling_its_run_keeps_it_going_and_fast_runs_are_left_alone(
    server: Server,
) -> None:
    with server.stranger() as owner:
        rid = start(owner)["id"]
        for _ in range(8):  # 4 s: past the grace period, by requests about the run
            assert owner.get(f"/runs/{rid}").json()["status"] == "running"
            asyncio.run(asyncio.sleep(0.5))
        owner.post(f"/runs/{rid}/stop")


def test_live_runs_per_identity_429_while_others_can_still_start(server: Server) -> None:
    with server.stranger() as greedy, server.stranger() as other:
        ids = [start(greedy)["id"] for _ in range(3)]
        r = greedy.post("/runs", json=LONG)
        assert r.status_code == 429, r.text
        assert "ELAB_MAX_LIVE_PER_IDENTITY = 3" in r.json()["error"]["message"]
        assert int(r.headers["retry-after"]) > 0
        theirs = start(other)["id"]
        for rid in ids:
            greedy.post(f"/runs/{rid}/stop")
        other.post(f"/runs/{theirs}/stop")


def test_api_tokens_act_as_their_owner_and_stop_working_when_revoked(server: Server) -> None:
    with server.stranger() as browser:
        me = browser.get("/me").json()
        made = browser.post("/tokens", json={"name": "autograder"})
        assert made.status_code == 201, made.text
        token = made.json()["token"]
        assert [t["name"] for t in browser.get("/tokens").json()] == ["autograder"]
        script = httpx.Client(
            base_url=server.url + "/api/v1", headers={"authorization": f"Bearer {token}"}
        )
        assert script.get("/me").json() == {**me, "via": "token"}
        assert "set-cookie" not in script.get("/me").headers  # a token needs no cookie
        rid = start(script)["id"]
        assert browser.get(f"/runs/{rid}").json()["mine"] is True  # the same identity

        async def control_by_token() -> str:
            w = await Watcher.open(server.ws_url, rid, as_=script)
            await w.conn.send(json.dumps({"type": "stop"}))
            status = await w.until_status({"stopped"})
            await w.conn.close()
            return str(status["error"])

        assert asyncio.run(control_by_token()) == "stopped by its owner"
        assert browser.get("/tokens").json()[0]["last_used"] is not None
        token_id = made.json()["id"]
        with server.stranger() as other:
            assert other.delete(f"/tokens/{token_id}").status_code == 404  # not theirs
        assert browser.delete(f"/tokens/{token_id}").status_code == 204
        r = script.get("/me")
        assert r.status_code == 401 and "unknown or revoked" in r.json()["error"]["message"]
        assert r.headers["www-authenticate"].startswith("Bearer")
        bad = httpx.get(server.url + "/api/v1/me", headers={"authorization": "Bearer nope"})
        assert bad.status_code == 401
        script.close()


def test_signing_out_returns_to_the_browsers_own_identity(server: Server) -> None:
    with server.stranger() as c:
        anonymous = c.get("/me").json()
        signed_in = c.post("/session", json={"name": "prof", "password": PASSWORD}).json()
        assert (signed_in["role"], signed_in["via"], signed_in["id"]) == (
            "instructor",
            "session",
            "i-prof",
        )
        assert c.get("/me").json() == signed_in
        assert c.delete("/session").json() == anonymous
        assert c.get("/me").json() == anonymous


def test_instructor_sign_in_refuses_wrong_passwords_and_guessing(tmp_path: Path) -> None:
    # a server of its own: the failures count per address (all tests come from 127.0.0.1)
    srv = Server(tmp_path / "data", ELAB_INSTRUCTORS=str(instructors_file(tmp_path))).start()
    try:
        with srv.stranger() as c:
            r = c.post("/session", json={"name": "prof", "password": "wrong"})
            assert r.status_code == 401 and r.json()["error"]["code"] == "unauthorized"
            assert c.get("/me").json()["role"] == "student"
            r = c.post("/session", json={"name": "nobody", "password": "x"})
            assert r.json()["error"]["message"] == "unknown instructor or wrong password"
            for _ in range(3):
                c.post("/session", json={"name": "prof", "password": "guess"})
            r = c.post("/session", json={"name": "prof", "password": PASSWORD})
            assert r.status_code == 429 and int(r.headers["retry-after"]) > 0  # wait a minute
            assert "5 failed sign-ins" in r.json()["error"]["message"]
            assert c.get("/me").json()["role"] == "student"
    finally:
        srv.stop()


def test_requests_from_other_sites_and_hosts_are_refused(server: Server) -> None:
    with server.client() as c:
        rid = start(c)["id"]
        foreign = {"origin": "http://127.0.0.1:1"}  # another port: another origin
        r = c.post(f"/runs/{rid}/stop", headers=foreign)
        assert r.status_code == 403 and "may not use this lab" in r.json()["error"]["message"]
        r = c.post(f"/runs/{rid}/stop", headers={"sec-fetch-site": "cross-site"})
        assert r.status_code == 403
        r = c.post(
            "/runs",
            content=json.dumps(LONG),
            headers={"content-type": "text/plain"},  # what a page may send without asking
        )
        assert r.status_code == 415 and "application/json" in r.json()["error"]["message"]
        own = {"origin": server.url, "sec-fetch-site": "same-origin"}  # the lab's own page
        assert c.get(f"/runs/{rid}").json()["status"] == "running"
        r = httpx.get(server.url + "/api/v1/me", headers={"host": "evil.example:80"})
        assert r.status_code == 400 and "ELAB_HOSTS" in r.json()["error"]["message"]

        async def foreign_websocket() -> int:
            try:
                async with connect(
                    f"{server.ws_url}/api/v1/runs/{rid}/stream",
                    subprotocols=["elab.v1"],  # type: ignore[list-item]
                    origin="http://evil.example",  # type: ignore[arg-type]
                ):
                    return 101
            except InvalidStatus as exc:
                return exc.response.status_code

        assert asyncio.run(foreign_websocket()) == 403
        assert c.post(f"/runs/{rid}/stop", headers=own).status_code == 200


def test_every_response_carries_the_security_headers(server: Server) -> None:
    for path in ("/", "/api/v1/plants", "/api/v1/runs/r-nothing"):
        h = httpx.get(server.url + path).headers
        csp = h["content-security-policy"]
        assert "script-src 'self'" in csp and "unsafe-inline" not in csp.split("style-src")[0]
        assert "frame-ancestors 'none'" in csp
        assert h["x-content-type-options"] == "nosniff"
        assert h["referrer-policy"] == "same-origin"


def test_a_new_browser_gets_a_signed_httponly_samesite_cookie(server: Server) -> None:
    r = httpx.get(server.url + "/")
    cookie = r.headers["set-cookie"]
    assert cookie.startswith("elab_id=a-") and "HttpOnly" in cookie and "SameSite=Lax" in cookie
    value = cookie.split(";")[0].split("=", 1)[1]
    forged = value.split(".")[0] + ".forged"
    r = httpx.get(server.url + "/api/v1/me", cookies={"elab_id": forged})
    assert r.json()["id"] != value.split(".")[0]  # a forged cookie is a new visitor


def test_kept_runs_storage_uploads_and_identifications_are_budgeted_per_identity(
    tmp_path: Path,
) -> None:
    srv = Server(
        tmp_path / "data",
        ELAB_MAX_RUNS_PER_IDENTITY="3",
        ELAB_MAX_STORAGE_PER_IDENTITY=str(3 << 20),
        ELAB_MAX_UPLOADS_PER_IDENTITY="1",
        ELAB_MAX_IDENT_PER_IDENTITY="1",
        ELAB_IDENT_WORKERS="2",
        ELAB_RETENTION="3",
    ).start()
    fast = {"plant": "belt_conveyor", "pace": "fast"}
    try:
        with srv.stranger() as me, srv.stranger() as other:
            # storage: belt conveyor runs record 8 channels of 8 bytes a sample (1 kHz)
            r = me.post("/runs", json={**fast, "duration": 70})  # 4.5 MB > 3 MiB
            assert r.status_code == 429, r.text
            message = r.json()["error"]["message"]
            assert "ELAB_MAX_STORAGE_PER_IDENTITY = 3.0 MiB" in message, message
            assert "this one needs 4.3 MiB" in message, message
            ids = [me.post("/runs", json={**fast, "duration": 1}).json()["id"] for _ in range(3)]
            r = me.post("/runs", json={**fast, "duration": 1})
            assert r.status_code == 429 and "ELAB_MAX_RUNS_PER_IDENTITY = 3" in r.text
            assert int(r.headers["retry-after"]) >= 3  # the retention frees room
            assert other.post("/runs", json={**fast, "duration": 1}).status_code == 201

            # retention: ended runs go 3 s after they ended, and the budget is free again
            until(lambda: all(me.get(f"/runs/{i}").status_code == 404 for i in ids), 30)
            assert me.post("/runs", json={**fast, "duration": 1}).status_code == 201

            # one identification at a time per identity
            excited = {"excitation": {"kind": "prbs", "amplitude": 1.0}, "duration": 20}
            rid = other.post("/runs", json={**fast, **excited}).json()["id"]
            until(lambda: other.get(f"/runs/{rid}").json()["finished_at"], 30)
            heavy = {
                "data": {"source": "run", "run": rid, "input": ["u"], "output": ["x"]},
                # seconds of work: the second request comes while it is being done
                "models": [{"kind": "oe", "nb": 6, "nf": 6, "nk": 1}],
            }
            light = {**heavy, "models": [], "correlation": False, "spectral": False}

            async def two_at_once() -> list[httpx.Response]:
                async with httpx.AsyncClient(
                    base_url=srv.url + "/api/v1", cookies=me.cookies, timeout=120
                ) as c:
                    first = asyncio.create_task(c.post("/ident", json=heavy))
                    while (await c.get("/server")).json()["ident"]["busy"] == 0:
                        await asyncio.sleep(0.02)  # the first is being worked on
                    second = await c.post("/ident", json=light)
                    return [await first, second]

            first, second = asyncio.run(two_at_once())
            assert first.status_code == 200, first.text[:300]
            assert second.status_code == 429, second.text[:300]
            assert "ELAB_MAX_IDENT_PER_IDENTITY = 1" in second.json()["error"]["message"]
            # another identity is not held by this one's budget (on a file: the run may be
            # gone by now, 3 s after it ended, while the heavy OE fits from their starts)
            t = np.arange(400) * 0.01
            table = "u,x\n" + "".join(f"{np.sin(3 * a)},{np.sin(3 * a - 0.5)}\n" for a in t)
            on_file = {
                **light,
                "data": {
                    "source": "file",
                    "text": table,
                    "input": ["u"],
                    "output": ["x"],
                    "Ts": 0.01,
                },
            }
            r = other.post("/ident", json=on_file)
            assert r.status_code == 200, r.text[:300]
    finally:
        srv.stop()


def test_a_run_deleted_while_it_downloads_is_hidden_at_once_and_the_download_completes(
    server: Server,
) -> None:
    with server.stranger() as me:
        rid = start(me, plant="flexible_link", pace="fast", duration=120)["id"]
        until(lambda: me.get(f"/runs/{rid}").json()["finished_at"], 60)
        whole = me.get(f"/runs/{rid}/data").content
        with me.stream("GET", f"/runs/{rid}/data") as r:
            parts = r.iter_bytes()
            got = next(parts)
            assert me.delete(f"/runs/{rid}").status_code == 204
            assert me.get(f"/runs/{rid}").status_code == 404  # gone for everyone else
            assert rid not in [x["id"] for x in me.get("/runs?owner=me").json()["runs"]]
            got += b"".join(parts)
        assert got == whole  # the download under way lost nothing
        assert me.get(f"/runs/{rid}/data").status_code == 404
    assert "Traceback" not in server.log
