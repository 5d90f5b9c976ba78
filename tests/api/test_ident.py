"""Identification over the API, against a real server: an uploaded file (the hair-dryer
data with its published results), a recorded run, progress lines, and bad data."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from elab.api import schemas as s
from tests.api.server import Server

DRYER = Path(__file__).resolve().parents[1] / "reference" / "ident" / "dryer.dat"


def _file(text: str | None = None, **over: Any) -> dict[str, Any]:
    data = {
        "source": "file",
        "format": "csv",
        "name": "dryer.dat",
        "text": DRYER.read_text() if text is None else text,
        "input": ["c1"],
        "output": ["c2"],
        "Ts": 0.08,
    }
    return data | over


def _ident(server: Server, body: dict[str, Any], **headers: str) -> Any:
    with server.client() as c:
        return c.post("/ident", json=body, headers=headers, timeout=120)


def test_dryer_upload_reproduces_the_published_results(server: Server) -> None:
    r = _ident(
        server,
        {
            "data": _file(),
            "arx_search": {"na": [1, 10], "nb": [1, 10], "nk": [3, 3]},
            "horizon": 16,
            "n4sid_orders": [1, 10],
            "models": [{"kind": "arx", "na": 2, "nb": 2, "nk": 3}, {"kind": "n4sid", "order": 4}],
        },
    )
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["data"]["N"] == 1000 and out["data"]["estimation"] == 500
    a = out["analyses"]
    assert a["correlation"]["delay"] == 3
    assert a["arx_search"]["best"] == [4, 4, 3]
    assert min(row[3] for row in a["arx_search"]["rows"]) == pytest.approx(0.0022583, rel=0.01)
    assert a["n4sid_orders"]["singular_values"][:3] == pytest.approx(
        [39.13, 9.925, 2.132], rel=1.5e-3
    )
    assert len(a["spectral"]["omega"]) == 128
    said = {v["topic"]: v for v in out["verdicts"]}  # on the data: open loop, a good record
    assert said["feedback"]["level"] == "good" and said["delay"]["finding"].startswith("delay 3")
    assert all(v["level"] == "good" for v in out["verdicts"] if v["topic"] != "order_search")
    arx, ss = out["models"]
    assert arx["level"] in ("good", "caution") and ss["level"] in ("good", "caution")
    assert arx["name"] == "arx 2 2 3"
    assert arx["parameters"]["A"] == pytest.approx([1, -1.2765, 0.3967], abs=5e-4)
    assert arx["fit"]["validation_simulation"][0] == pytest.approx(89.55, abs=0.3)
    assert ss["fit"]["validation_simulation"][0] >= 89
    assert ss["orders"] == {"n": 4, "horizon": 16} and ss["stable"]
    assert len(ss["poles"]) == 4 and ss["continuous"] is not None
    assert arx["residuals"]["bound"] == pytest.approx(2.58 / np.sqrt(500))
    assert len(arx["simulated"][0]) == 500


def test_progress_lines_then_the_result(server: Server) -> None:
    models = [{"kind": "arx", "na": 2, "nb": 2, "nk": 3}, {"kind": "n4sid", "order": 2}]
    r = _ident(
        server,
        {"data": _file(), "arx_search": {"nk": [1, 10]}, "models": models},
        accept="application/x-ndjson",
    )
    assert r.status_code == 200 and r.headers["content-type"].startswith("application/x-ndjson")
    for line in r.text.splitlines():  # every line is an IdentLine of the wire schema
        s.IdentLine.model_validate_json(line)
    lines = [json.loads(x) for x in r.text.splitlines()]
    progress = [ln["progress"]["done"] for ln in lines[:-1]]
    assert len(progress) >= 10 and progress == sorted(progress) and progress[-1] == 1.0
    # each model is named before it is estimated (seconds each: never a silent bar)
    stages = [ln["progress"]["stage"] for ln in lines[:-1]]
    estimated = lines[-1]["result"]["models"]
    n = len(estimated)
    assert n == 2 and [st for st in stages if st.startswith("estimating ")] == [
        f"estimating {m['name']}, model {i + 1} of {n}" for i, m in enumerate(estimated)
    ], stages
    search = lines[-1]["result"]["analyses"]["arx_search"]
    assert len(search["rows"]) == 1000  # struc(1:10, 1:10, 1:10)
    assert min(row[3] for row in search["rows"]) <= 0.0022583  # [4 4 3] is among them


def test_a_recorded_identification_run(server: Server) -> None:
    with server.client() as c:
        run = c.post(
            "/runs",
            json={
                "plant": "flexible_link",
                "experiment": "identification",
                "pace": "fast",
                "duration": 20,
                "signal": {"kind": "step", "amplitude": 0},
                "excitation": {"kind": "prbs", "amplitude": 1.0, "order": 11, "band": 0.05},
                "excitation_at": "input",
                "seed": 1,
                "quantize": False,  # noise only (identification's default also quantises)
            },
        ).json()
        for _ in range(200):
            if c.get(f"/runs/{run['id']}").json()["status"] == "finished":
                break
            time.sleep(0.1)
    r = _ident(
        server,
        {
            "data": {
                "source": "run",
                "run": run["id"],
                "input": ["u"],
                "output": ["theta", "alpha"],
            },
            "models": [{"kind": "n4sid", "order": 0, "horizon": 20}],
        },
    )
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["data"]["output_units"] == ["rad", "rad"] and out["data"]["Ts"] == 0.001
    assert out["analyses"]["correlation"] is None and out["notes"]  # two outputs
    m = out["models"][0]
    assert min(m["fit"]["validation_one_step"]) > 90
    r = _ident(
        server,
        {
            "data": {"source": "run", "run": run["id"]},  # θ by default
            "models": [{"kind": "arx", "na": 4, "nb": 4, "nk": 1}],
        },
    )
    assert r.status_code == 200, r.text
    assert r.json()["data"]["output_names"] == ["theta"]
    # the run had the predefined controller: the verdict knows it ran in closed loop, and
    # the delay from correlation analysis is not to be trusted there
    said = {v["topic"]: v for v in r.json()["verdicts"]}
    assert "closed loop" in said["feedback"]["finding"]
    assert said["delay"]["level"] == "caution" and "closed-loop" in said["delay"]["finding"]
    # and the model is measured against the plant's own model (θ/u of the link)
    physics = [v for v in r.json()["models"][0]["verdicts"] if v["topic"] == "physics"]
    assert len(physics) == 1 and physics[0]["finding"].startswith("theta: up to ")
    assert "rad/s" in physics[0]["finding"] and "nominal" not in physics[0]["finding"]


def _finished_run(server: Server, body: dict[str, Any]) -> str:
    with server.client() as c:
        run = c.post("/runs", json=body).json()
        for _ in range(600):
            if c.get(f"/runs/{run['id']}").json()["status"] == "finished":
                return str(run["id"])
            time.sleep(0.1)
    raise AssertionError(f"run {run['id']} did not finish in 60 s")


def test_the_two_stage_method_reads_a_runs_reference_and_excitation(server: Server) -> None:
    """``two_stage`` on a closed-loop run: stage 1 predicts u from the recorded r and the
    run's input excitation (reproduced from its request, not recorded), fitted on the
    estimation part; the answer equals the library's on the downloaded recording with
    the same references, and the validation part keeps the measured u."""
    prbs = {"kind": "prbs", "amplitude": 1.0, "order": 10, "band": 0.05}
    square = {"kind": "square", "amplitude": 0.2, "period": 10}
    rid = _finished_run(
        server,
        {
            "plant": "flexible_link",
            "experiment": "identification",
            "pace": "fast",
            "duration": 30,
            "signal": square,
            "excitation": prbs,
            "excitation_at": "input",
            "seed": 4,
        },
    )
    body = {
        "data": {"source": "run", "run": rid},
        "detrend": "none",
        "decimate": 10,
        "correlation": False,
        "spectral": False,
        "two_stage": 1000,
        "models": [{"kind": "oe", "nb": 4, "nf": 4, "nk": 1}],
    }
    r = _ident(server, body)
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["notes"][0].startswith(
        "two-stage method: the estimation part's u replaced by its prediction from r, "
        "excitation (a FIR of 1000 taps"
    ), out["notes"]
    said = {v["topic"]: v for v in out["verdicts"]}
    assert said["feedback"]["level"] == "good" and "two-stage" in said["feedback"]["finding"]
    assert said["two_stage"]["level"] == "good"
    model = out["models"][0]
    assert model["level"] != "poor", model["verdicts"]
    physics = {v["topic"]: v for v in model["verdicts"]}["physics"]
    assert physics["level"] != "poor", physics

    # the library on the downloaded recording, with the excitation made from its request
    from elab.ident import iddata
    from elab.ident import workflow as wf
    from elab.ident.closedloop import References
    from elab.sim.signals import PRBS

    with server.client() as c:
        rec = c.get(f"/runs/{rid}/data?format=json&channels=r,u,theta").json()["data"]
    u, theta, ref = (np.array(rec[k]) for k in ("u", "theta", "r"))
    e = PRBS(1.0, order=10, band=0.05).sample(0, u.size, 0.001)
    z = iddata(theta, u, 0.001, output_names=("theta",), input_names=("u",))
    plan = wf.Plan(
        models=(wf.parse_model("oe:4,4,1"),),
        detrend="none",
        decimate=10,
        correlation=False,
        spectral=False,
        closed_loop=True,
        two_stage=1000,
    )
    mine = wf.run(z, plan, references=References(np.column_stack([ref, e]), ("r", "excitation")))
    fit = mine.models[0].fits.headline_fit.fit[0]
    assert model["fit"]["headline"][0] == pytest.approx(fit, abs=1e-6)
    # the data as analysed: the validation part is the measured u (decimated), the
    # estimation part its prediction
    shown = np.array(out["data"]["u"][0])
    step, n_est = out["data"]["step"], out["data"]["estimation"]
    measured = z.decimate(10).u[::step, 0]
    k = -(-n_est // step)  # the first shown validation sample
    np.testing.assert_allclose(shown[k:], measured[k:], atol=1e-9)
    assert np.max(np.abs(shown[:k] - measured[:k])) > 1e-3

    # names that are not the run's, and a run without an input excitation
    bad = body | {"data": {"source": "run", "run": rid, "reference": ["w"]}}
    err = _error(_ident(server, bad))
    assert err["field"] == "data.reference" and "or excitation" in err["message"]
    del body["two_stage"]
    assert "two-stage" not in _ident(server, body).json()["notes"][0]


def test_a_run_whose_references_never_vary_is_refused_by_name(server: Server) -> None:
    """A closed-loop run held at one reference, no excitation: nothing drove its loop from
    outside, and the two-stage request says so about ``data.reference``."""
    rid = _finished_run(
        server,
        {
            "plant": "flexible_link",
            "pace": "fast",
            "duration": 2,
            "signal": {"kind": "step", "amplitude": 0.1},
        },
    )
    body = {"data": {"source": "run", "run": rid}, "detrend": "none", "two_stage": 40}
    err = _error(_ident(server, body | {"models": [{"kind": "oe", "nb": 2, "nf": 2, "nk": 1}]}))
    assert err["field"] == "data.reference" and "varies" in err["message"], err


def test_the_two_stage_method_on_a_file_reads_its_reference_columns(server: Server) -> None:
    from elab.ident import iddata
    from elab.ident import workflow as wf
    from elab.ident.closedloop import References
    from tests.unit.ident.test_closedloop import closed_loop

    data, r = closed_loop(11)
    text = "r,u,y\n" + "".join(
        f"{float(a)!r},{float(b)!r},{float(c)!r}\n"
        for a, b, c in zip(r, data.u[:, 0], data.y[:, 0], strict=True)
    )
    body = {
        "data": _file(text, input=["u"], output=["y"], Ts=0.01, reference=["r"]),
        "detrend": "none",
        "correlation": False,
        "spectral": False,
        "two_stage": 40,
        "models": [{"kind": "oe", "nb": 1, "nf": 1, "nk": 1}],
    }
    r_ = _ident(server, body)
    assert r_.status_code == 200, r_.text
    plan = wf.Plan(
        models=(wf.parse_model("oe:1,1,1"),),
        detrend="none",
        correlation=False,
        spectral=False,
        two_stage=40,
    )
    z = iddata(data.y[:, 0], data.u[:, 0], 0.01)
    mine = wf.run(z, plan, references=References(r[:, None], ("r",)))
    got = r_.json()["models"][0]["fit"]["headline"][0]
    assert got == pytest.approx(mine.models[0].fits.headline_fit.fit[0], abs=1e-9)
    # a file names its references; a column it lacks is named as the reference
    err = _error(_ident(server, body | {"data": body["data"] | {"reference": None}}))
    assert err["field"] == "data.reference" and "drove the loop" in err["message"]
    err = _error(_ident(server, body | {"data": body["data"] | {"reference": ["w"]}}))
    assert err["field"] == "data.reference" and "r, u, y" in err["message"]


def test_the_indirect_method_on_a_file_equals_the_librarys(server: Server) -> None:
    from elab.ident import workflow as wf
    from elab.ident.closedloop import Controller
    from tests.unit.ident.test_closedloop import closed_loop

    data, _ = closed_loop(14)
    text = "u,y\n" + "".join(
        f"{float(b)!r},{float(c)!r}\n" for b, c in zip(data.u[:, 0], data.y[:, 0], strict=True)
    )
    body = {
        "data": _file(text, input=["u"], output=["y"], Ts=0.01),
        "detrend": "none",
        "correlation": False,
        "spectral": False,
        "indirect": {"num": [0.6], "den": [1]},
        "models": [{"kind": "oe", "nb": 1, "nf": 1, "nk": 1}],
    }
    r = _ident(server, body)
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["models"][0]["name"] == "oe 1 1 1 (indirect)"
    assert out["notes"][0].startswith("indirect method: the models were fitted to the loop")
    plan = wf.Plan(
        models=(wf.parse_model("oe:1,1,1"),),
        detrend="none",
        correlation=False,
        spectral=False,
        indirect=Controller((0.6,), (1.0,)),
    )
    mine = wf.run(data, plan).models[0]
    got = out["models"][0]["fit"]["headline"][0]
    assert got == pytest.approx(mine.fits.headline_fit.fit[0], abs=1e-9)
    # the controller and the method are checked by name
    for indirect, field in (
        ({"num": [0.6], "den": [0, 1]}, "indirect.den"),
        ({"num": [], "den": [1]}, "indirect.num"),
        ({"num": [0.6], "den": [5e-324]}, "indirect"),  # C(q) y overflows on the data
        ({"num": [1e308], "den": [1]}, "indirect"),
    ):
        assert _error(_ident(server, body | {"indirect": indirect}))["field"] == field
    err = _error(_ident(server, body | {"two_stage": 40}))
    assert err["field"] == "indirect" and "one closed-loop method at a time" in err["message"]


def _error(r: Any, status: int = 422) -> dict[str, Any]:
    assert r.status_code == status, r.text
    err: dict[str, Any] = r.json()["error"]
    return err


def _rows(pairs: list[tuple[str, str]]) -> str:
    return "u,y\n" + "\n".join(f"{u},{y}" for u, y in pairs) + "\n"


def test_bad_data_get_clear_errors(server: Server) -> None:
    rng = np.random.default_rng(0)
    good = [(f"{u:.4f}", f"{y:.4f}") for u, y in rng.standard_normal((200, 2))]
    named = {"input": ["u"], "output": ["y"]}
    nan = good.copy()
    nan[17] = ("nan", "1")
    err = _error(_ident(server, {"data": _file(_rows(nan), **named)}))
    assert err["field"] == "data row 18" and "finite" in err["message"]  # the file's row
    const = [("1.0", y) for _, y in good]
    err = _error(_ident(server, {"data": _file(_rows(const), **named)}))
    assert "constant" in err["message"] and "persistently exciting" in err["message"]
    short = _rows(good) + "0.5\n"
    err = _error(_ident(server, {"data": _file(short, **named)}))
    assert "data" in err["field"]
    err = _error(_ident(server, {"data": _file(_rows(good), **named, Ts=None)}))
    assert err["field"] == "data.Ts" and "sample time" in err["message"]
    err = _error(
        _ident(
            server,
            {
                "data": _file(_rows(good[:12]), **named),
                "correlation": False,
                "spectral": False,
                "models": [{"kind": "arx", "na": 8, "nb": 8, "nk": 1}],
            },
        )
    )
    assert err["field"] == "models[0].data" and "samples" in err["message"]
    err = _error(_ident(server, {"data": _file(_rows(good), input=["x"], output=["y"])}))
    assert err["field"] == "data.input" and "u, y" in err["message"]
    err = _error(_ident(server, {"data": _file(), "arx_search": {"na": [5, 1]}}))
    assert err["field"] == "arx_search.na"
    err = _error(_ident(server, {"data": _file(), "models": [{"kind": "bj"}]}))
    assert err["field"].startswith("models.0")
    err = _error(_ident(server, {"data": {"source": "run", "run": "nope"}}), 404)
    assert "nope" in err["message"]
    huge = "u,y\n" + "1.0,2.0\n" * 2_300_000  # > 16 MiB
    err = _error(_ident(server, {"data": _file(huge, **named)}), 413)
    assert "ELAB_MAX_UPLOAD" in err["message"]
    with server.client() as c:  # the server is fine afterwards
        assert c.get("/plants").status_code == 200


def test_the_plants_rest_is_taken_off_a_runs_channels(server: Server) -> None:
    """``detrend: "operating_point"``: the upright pendulum's β₂ is identified about its
    rest (π), not about its mean, and the note says what was taken off; a file has no
    rest to take off, and is refused by name."""
    rid = _finished_run(
        server,
        {
            "plant": "double_pendulum",
            "experiment": "identification",
            "pace": "fast",
            "duration": 4,
            "signal": {"kind": "step", "amplitude": 0},
            "excitation": {"kind": "prbs", "amplitude": 1.0, "order": 10, "band": 0.05},
            "excitation_at": "input",
            "quantize": False,  # quantised, β₁ moves less than one encoder count
        },
    )
    body = {
        "data": {"source": "run", "run": rid, "output": ["alpha", "beta1", "beta2"]},
        "detrend": "operating_point",
        "correlation": False,
        "spectral": False,
        "models": [{"kind": "n4sid", "order": 6, "horizon": 20}],
    }
    r = _ident(server, body)
    assert r.status_code == 200, r.text[:500]
    out = r.json()
    beta2 = np.array(out["data"]["y"][2])
    assert np.all(np.abs(beta2) < 0.05), beta2[:5]  # about 0: π taken off, as recorded
    assert np.std(beta2) > 0 and abs(np.mean(beta2)) > 1e-6  # no mean taken off either
    note = next(n for n in out["notes"] if n.startswith("the plant's rest taken off"))
    assert "beta2 3.14159" in note and "u 0" in note
    # the plant is unstable: a note says its model's poles are kept, and the stability
    # verdict judges the model against the plant's unstable pole (|z| = 1.0052; whether this
    # short, noisy record's estimate is near it is the verdict's to say)
    assert any(n.startswith("the plant is unstable") for n in out["notes"]), out["notes"]
    said = {v["topic"]: v for v in out["models"][0]["verdicts"]}
    assert "the plant" in said["stability"]["finding"], said["stability"]
    finding = said["stability"]["finding"]
    # the physics' pole at this sample time, printed to four figures, is the plant's
    # (|z| = 1.0052); the model's largest pole is whatever this short record gives, and the
    # grade must agree with it: unstable past half the plant's margin is "good"
    top = float(re.search(r"the largest pole at \|z\| = ([0-9.e+-]+)", finding)[1])
    plant = float(re.search(r"physics(?:' | has a pole at \|z\| = )([0-9.]+)", finding)[1])
    assert plant == pytest.approx(1.0052, abs=6e-4), finding
    assert said["stability"]["level"] == ("good" if top >= 1 + (plant - 1) / 2 else "poor"), said
    table = "u,y\n" + "".join(f"{np.sin(k / 7)},{np.cos(k / 5)}\n" for k in range(400))
    file = {"source": "file", "text": table, "input": ["u"], "output": ["y"], "Ts": 0.01}
    err = _error(_ident(server, body | {"data": file, "models": []}), 422)
    assert err["field"] == "detrend" and "a file's" in err["message"]
