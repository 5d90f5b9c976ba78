"""Uploaded controllers against a real server: templates, uploads in every format with
their report, runs made with them equal to runs with the same law given inline, owners,
and random and mutated files (hypothesis): no 500, nothing stored for a refused file."""

from __future__ import annotations

import asyncio
import base64
import io
import json
import random
from pathlib import Path

import httpx
import numpy as np
import pytest
import scipy.io
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from elab.controllers import read_controller
from elab.plants import PLANTS, get_plant
from tests.api.server import Server, Watcher, until

SEED_LQR = [20, -93.5614, 3.3621, 0.9623]
TOML = f'version = 1\nname = "seed LQR"\nkind = "state_feedback"\nK = {SEED_LQR}\n'


def upload(c: object, plant: str, fmt: str, content: str, **extra: object) -> object:
    return c.post(  # type: ignore[attr-defined]
        "/controllers", json={"plant": plant, "format": fmt, "content": content, **extra}
    )


def b64(data: bytes) -> str:
    return base64.b64encode(data).decode()


@pytest.mark.parametrize("fmt", ["toml", "json", "mat", "npz"])
@pytest.mark.parametrize("plant_id", list(PLANTS))
def test_each_template_downloads_and_reads_back_as_the_predefined_controller(
    server: Server, plant_id: str, fmt: str
) -> None:
    with server.client() as c:
        r = c.get(f"/plants/{plant_id}/controller-template", params={"format": fmt})
        assert r.status_code == 200, r.text
        assert f"{plant_id}-controller.{fmt}" in r.headers["content-disposition"]
        plant = get_plant(plant_id)
        assert read_controller(r.content, fmt, plant).law == plant.predefined


def test_an_uploaded_controller_runs_as_the_same_law_given_inline(server: Server) -> None:
    with server.client() as c:
        r = upload(c, "flexible_link", "toml", TOML)
        assert r.status_code == 201, r.text
        up = r.json()
        assert up["name"] == "seed LQR" and up["mine"] is True
        assert up["controller"] == {
            "kind": "state_feedback",
            "K": SEED_LQR,
            "estimate": "velocity_filters",
            "Nr": None,
            "L": None,
            "observer_poles": None,
        }
        rep = up["report"]
        assert rep["stable"] and rep["rig_ready"] and rep["domain"] == "s"
        assert rep["peak_u"] == pytest.approx(20 * np.radians(30), rel=1e-6)
        assert any("saturates" in w for w in rep["warnings"])
        assert c.get(f"/controllers/{up['id']}").json() == up
        assert up["url"] == f"/api/v1/controllers/{up['id']}"
        assert c.get("/controllers").json()["controllers"][0]["id"] == up["id"]

        common = {"plant": "flexible_link", "pace": "fast", "duration": 3, "seed": 7}
        by_id = c.post("/runs", json={**common, "controller_id": up["id"]}).json()
        inline = c.post("/runs", json={**common, "controller": up["controller"]}).json()
        assert by_id["request"]["controller"] == up["controller"]  # recorded as it ran
        assert by_id["request"]["controller_id"] == up["id"]
        for run in (by_id, inline):
            until(lambda run=run: c.get(f"/runs/{run['id']}").json()["finished_at"], 30)
        a = c.get(f"/runs/{by_id['id']}/data", params={"format": "json"}).json()["data"]
        b = c.get(f"/runs/{inline['id']}/data", params={"format": "json"}).json()["data"]
        assert a == b and len(a["u"]) == 3000  # the same bits, sample for sample


def test_matlab_and_numpy_files_upload_as_base64(server: Server) -> None:
    buf = io.BytesIO()
    scipy.io.savemat(buf, {"Kp": 12.0, "Ki": 0.49, "Kd": 0.5})
    npz = io.BytesIO()
    np.savez(npz, K=np.array([SEED_LQR]))
    with server.client() as c:
        r = upload(c, "belt_conveyor", "mat", b64(buf.getvalue()), name="seed PID")
        assert r.status_code == 201, r.text
        assert r.json()["controller"] == {
            "kind": "pid",
            "Kp": 12.0,
            "Ki": 0.49,
            "Kd": 0.5,
            "N": 10.0,
            "Tt": None,
            "b": 1.0,
            "c": 1.0,
        }
        r = upload(c, "flexible_link", "npz", b64(npz.getvalue()))
        assert r.status_code == 201 and r.json()["controller"]["K"] == SEED_LQR
        r = upload(c, "flexible_link", "mat", "not base64!")
        assert r.status_code == 422 and r.json()["error"]["field"] == "content"


def test_a_controller_is_its_owners_and_for_its_plant(server: Server) -> None:
    with server.client() as owner, server.stranger() as other:
        cid = upload(owner, "flexible_link", "toml", TOML).json()["id"]
        assert other.get(f"/controllers/{cid}").status_code == 404
        assert other.get("/controllers").json()["controllers"] == []
        r = other.post("/runs", json={"plant": "flexible_link", "controller_id": cid})
        assert r.status_code == 404
        assert other.delete(f"/controllers/{cid}").status_code == 404
        r = owner.post("/runs", json={"plant": "belt_conveyor", "controller_id": cid})
        assert r.status_code == 422 and "for flexible_link" in r.json()["error"]["message"]
        assert owner.delete(f"/controllers/{cid}").status_code == 204
        assert owner.get(f"/controllers/{cid}").status_code == 404


def test_a_live_run_switches_to_an_uploaded_controller(server: Server) -> None:
    with server.client() as c, server.stranger() as other:
        cid = upload(c, "flexible_link", "toml", TOML.replace("20,", "15,")).json()["id"]
        theirs = upload(other, "flexible_link", "toml", TOML).json()["id"]
        rid = c.post("/runs", json={"plant": "flexible_link", "duration": 30}).json()["id"]
        r = c.post(f"/runs/{rid}/params", json={"controller_id": cid})
        assert r.status_code == 200, r.text
        change = c.get(f"/runs/{rid}").json()["param_changes"][-1]
        assert change["params"]["controller_id"] == cid
        assert change["params"]["controller"]["K"][0] == 15
        r = c.post(f"/runs/{rid}/params", json={"controller_id": theirs})
        assert r.status_code == 404  # someone else's controller does not exist for us
        both = {"controller_id": cid, "controller": {"kind": "predefined"}}
        r = c.post(f"/runs/{rid}/params", json=both)
        assert r.status_code == 422 and r.json()["error"]["field"] == "controller_id"
        # back to the predefined gains, so that the upload over the websocket changes them
        # (a change that changes nothing is not applied)
        r = c.post(f"/runs/{rid}/params", json={"controller": {"kind": "predefined"}})
        assert [d["field"] for d in r.json()["changed"]] == ["controller.K.0"]

        async def over_the_websocket() -> dict[str, object]:
            w = await Watcher.open(server.ws_url, rid, as_=c)
            await w.conn.send(json.dumps({"type": "set_params", "controller_id": cid}))
            while (m := await w.next())["type"] != "params":
                pass
            await w.conn.close()
            return m

        notice = asyncio.run(over_the_websocket())
        assert notice["params"]["controller_id"] == cid  # type: ignore[index]
        c.post(f"/runs/{rid}/stop")


def test_uploads_at_once_cannot_pass_the_budget_together(tmp_path: Path) -> None:
    srv = Server(tmp_path / "data", ELAB_MAX_CONTROLLERS_PER_IDENTITY="3").start()

    async def six_at_once() -> list[int]:
        async with httpx.AsyncClient(base_url=srv.url + "/api/v1", timeout=60) as c:
            await c.get("/me")  # one identity for all six
            body = {"plant": "flexible_link", "format": "toml", "content": TOML}
            rs = await asyncio.gather(*(c.post("/controllers", json=body) for _ in range(6)))
            kept = (await c.get("/controllers")).json()["controllers"]
            assert len(kept) == 3, len(kept)
            return sorted(r.status_code for r in rs)

    try:
        assert asyncio.run(six_at_once()) == [201, 201, 201, 429, 429, 429]
    finally:
        srv.stop()


def test_a_refused_file_says_where_and_stores_nothing(server: Server) -> None:
    with server.stranger() as c:
        r = upload(c, "flexible_link", "toml", 'version = 1\nkind = = "pid"\n')
        assert r.status_code == 422, r.text
        assert "line 2, column 8" in r.json()["error"]["message"]
        r = upload(c, "flexible_link", "toml", 'version = 1\nkind = "state_feedback"\nK = [1]')
        assert r.status_code == 422 and r.json()["error"]["field"] == "K"
        assert c.get("/controllers").json()["controllers"] == []


def mutated(seed: int, text: str = TOML) -> str:
    """``text`` (the TOML template) with a few random edits: dropped, repeated or swapped
    bytes."""
    data = bytearray(text.encode())
    rng = random.Random(seed)
    for _ in range(rng.randint(1, 6)):
        i = rng.randrange(len(data))
        op = rng.choice(["drop", "dup", "byte"])
        if op == "drop":
            del data[i]
        elif op == "dup":
            data[i:i] = data[i : i + rng.randint(1, 8)]
        else:
            data[i] = rng.randrange(32, 127)
    return data.decode("utf-8", "replace")


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    content=st.one_of(
        st.integers(0, 10**6).map(mutated),
        st.text(min_size=1, max_size=300),
        st.binary(min_size=1, max_size=300).map(b64),
    ),
    fmt=st.sampled_from(["toml", "json", "mat", "npz"]),
)
def test_random_and_mutated_files_never_crash_and_refused_ones_are_not_kept(
    server: Server, content: str, fmt: str
) -> None:
    with server.stranger() as c:
        r = upload(c, "flexible_link", fmt, content)
        assert r.status_code in (201, 422), r.text[:300]
        kept = c.get("/controllers").json()["controllers"]
        assert len(kept) == (r.status_code == 201)


OBSERVER = (
    TOML.replace('name = "seed LQR"', 'name = "observer"\nestimate = "observer"\nNr = 20')
    + "observer_poles = [-40, -45, [-50, 8], [-50, -8]]\n"
)
CHAIN_FF = """version = 1
kind = "chain"
ff_num = [0.2]
ff_den = [0.1, 1]

[[blocks]]
kind = "pid"
Kp = 2.0
Ki = 0.5

[[blocks]]
kind = "lti"
num = [0.5, 1.0]
den = [0.05, 1.0]
"""


def test_an_observer_and_a_chain_with_feedforward_upload_and_run(server: Server) -> None:
    with server.client() as c:
        obs = upload(c, "flexible_link", "toml", OBSERVER).json()
        assert obs["controller"]["estimate"] == "observer" and obs["controller"]["Nr"] == 20
        poles = {(round(p["re"], 6), round(p["im"], 6)) for p in obs["report"]["poles"]}
        assert {(-40.0, 0.0), (-45.0, 0.0), (-50.0, 8.0), (-50.0, -8.0)} <= poles
        chain = upload(c, "belt_conveyor", "toml", CHAIN_FF)
        assert chain.status_code == 201, chain.text
        law = chain.json()["controller"]
        assert law["kind"] == "lti" and law["ff_num"] == [0.2] and len(law["A"]) == 2
        bad = upload(c, "belt_conveyor", "toml", CHAIN_FF.replace("Ki = 0.5", "Ki = 0.5\nb = 0.5"))
        assert bad.status_code == 422 and bad.json()["error"]["field"] == "blocks[0].b"
        runs = [
            c.post("/runs", json={"plant": p, "pace": "fast", "duration": 2, "controller_id": i})
            for p, i in (("flexible_link", obs["id"]), ("belt_conveyor", chain.json()["id"]))
        ]
        inline = c.post(
            "/runs",
            json={
                "plant": "flexible_link",
                "pace": "fast",
                "duration": 2,
                "controller": obs["controller"],
            },
        )
        for r in [*runs, inline]:
            assert r.status_code == 201, r.text
            rid = r.json()["id"]
            done = until(lambda rid=rid: (x := c.get(f"/runs/{rid}").json())["finished_at"] and x)
            assert done["status"] == "finished" and done["n_samples"] == 2000
        a = c.get(f"/runs/{runs[0].json()['id']}/data", params={"format": "json"}).json()
        b = c.get(f"/runs/{inline.json()['id']}/data", params={"format": "json"}).json()
        assert a["data"] == b["data"]


def test_a_file_uploads_as_a_form_as_curl_sends_it(server: Server) -> None:
    mat = io.BytesIO()
    scipy.io.savemat(mat, {"Kp": 12.0, "Ki": 0.49, "Kd": 0.5})
    with server.client() as c:
        before = len(c.get("/controllers").json()["controllers"])
        r = c.post(
            "/controllers",
            data={"plant": "belt_conveyor"},
            files={"file": ("seed_pid.mat", mat.getvalue(), "application/octet-stream")},
        )
        assert r.status_code == 201, r.text
        up = r.json()
        assert up["format"] == "mat" and up["name"] == "seed_pid.mat"
        assert up["controller"]["Kp"] == 12.0
        r = c.post(
            "/controllers",
            data={"plant": "flexible_link", "format": "toml", "name": "mine"},
            files={"file": ("ctrl.txt", TOML.encode(), "text/plain")},
        )
        assert r.status_code == 201 and r.json()["name"] == "mine"
        bad = [
            ({"plant": "flexible_link"}, {"x": ("c.toml", b"x", "t")}, "x"),
            ({"plant": "flexible_link"}, {"file": ("c.docx", b"x", "x/y")}, "file"),
            ({"plant": "flexible_link", "extra": "1"}, {"file": ("c.toml", b"x", "t")}, "extra"),
            ({"plant": "nowhere"}, {"file": ("c.toml", TOML.encode(), "t")}, "plant"),
            ({"plant": "flexible_link"}, {"file": ("c.toml", b"version = ", "t")}, "file"),
        ]
        for data, files, field in bad:
            r = c.post("/controllers", data=data, files=files)
            assert r.status_code == 422, (field, r.text)
            assert r.json()["error"]["field"] == field, (field, r.text)
        form = "multipart/form-data; boundary=x"
        only_plant = b'--x\r\ncontent-disposition: form-data; name="plant"\r\n\r\nflexible_link'
        r = c.post(
            "/controllers", content=only_plant + b"\r\n--x--\r\n", headers={"content-type": form}
        )
        assert r.status_code == 422 and r.json()["error"]["field"] == "file", r.text
        r = c.post("/controllers", content=b"--x\r\nbroken", headers={"content-type": form})
        assert r.status_code == 422, r.text
        # a form anywhere else is still refused
        r = c.post("/runs", data={"plant": "flexible_link"}, files={"f": ("a", b"b", "c")})
        assert r.status_code == 415
        kept = c.get("/controllers").json()["controllers"]
        assert len(kept) == before + 2  # nothing else kept
