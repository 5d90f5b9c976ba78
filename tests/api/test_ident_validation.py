"""A separate validation record over the API, against a real server: the hair-dryer
data's first 500 samples estimate, its last 500 validate, sent as two records; the fits
are the library's, and bad validation data get a 4xx that names the field."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.testing import assert_allclose

from elab.ident import workflow as wf
from elab.ident.data import MAX_SAMPLES
from elab.ident.files import read_table
from tests.api.server import Server

DRYER = Path(__file__).resolve().parents[1] / "reference" / "ident" / "dryer.dat"
ROWS = DRYER.read_text().splitlines()
ESTIMATION, VALIDATION = ROWS[:500], ROWS[500:]
MODELS = [{"kind": "arx", "na": 2, "nb": 2, "nk": 3}, {"kind": "n4sid", "order": 4, "horizon": 16}]


def _file(rows: list[str], **over: Any) -> dict[str, Any]:
    text = "".join(r + "\n" for r in rows)
    data = {"source": "file", "text": text, "input": ["c1"], "output": ["c2"], "Ts": 0.08}
    return data | over


def _ident(server: Server, body: dict[str, Any], **headers: str) -> Any:
    with server.client() as c:
        return c.post("/ident", json=body, headers=headers, timeout=120)


def _field_error(r: Any, field: str, *words: str, status: int = 422) -> str:
    """The error of ``r``: ``status``, naming ``field``, its message containing ``words``."""
    assert r.status_code == status, r.text[:500]
    err = r.json()["error"]
    assert err["field"] == field, err
    for word in words:
        assert word in err["message"], err
    return str(err["message"])


def test_two_records_give_the_library_s_fits(server: Server) -> None:
    body = {"data": _file(ESTIMATION), "validation": _file(VALIDATION), "models": MODELS}
    r = _ident(server, body)
    assert r.status_code == 200, r.text[:500]
    out = r.json()
    d = out["data"]
    assert (d["N"], d["estimation"], d["validation"]) == (1000, 500, "record")

    def dataset(rows: list[str]) -> Any:
        return read_table("\n".join(rows).encode(), "csv").dataset(["c1"], ["c2"], 0.08)

    plan = wf.Plan(
        models=(
            wf.ModelRequest("arx", {"na": 2, "nb": 2, "nk": 3}),
            wf.ModelRequest("n4sid", {"order": 4, "horizon": 16}),
        )
    )
    direct = wf.run(dataset(ESTIMATION), plan, validation=dataset(VALIDATION))
    assert [m["name"] for m in out["models"]] == [m.name for m in direct.models]
    for got, want in zip(out["models"], direct.models, strict=True):
        f = want.fits
        # words about the fits (which one heads)
        assert (got["fit"]["headline_x0"], got["fit"]["headline_why"]) == (
            f.headline.x0,
            f.headline.why,
        )
        for key, fit in (
            ("validation_simulation", f.validation_simulation),
            ("validation_simulation_x0", f.validation_simulation_x0),
            ("validation_one_step", f.validation_one_step),
            ("estimation_simulation", f.estimation_simulation),
            ("headline", f.headline_fit),
        ):
            # the same code on the same numbers (JSON carries floats exactly); 1e-9 allows
            # only a different summation order in the worker's BLAS
            assert_allclose(got["fit"][key], fit.fit, rtol=1e-9, err_msg=f"{got['name']} {key}")
    # the estimation record's means come off both (docs/identification.md): the
    # validation samples shown are the record's minus the estimation means
    est, val = dataset(ESTIMATION), dataset(VALIDATION)
    shown = np.asarray(d["y"][0][500:])
    assert_allclose(shown, val.y[:, 0] - est.y[:, 0].mean(), atol=1e-12)
    assert out["models"][0]["fit"]["validation_simulation"][0] > 80  # a good model still

    r = _ident(server, body, accept="application/x-ndjson")  # the stream: the same result
    last = json.loads(r.text.splitlines()[-1])
    assert last["result"] == out


def test_a_run_may_validate_a_run(server: Server) -> None:
    with server.client() as c:
        run = c.post(
            "/runs",
            json={
                "plant": "flexible_link",
                "experiment": "identification",
                "pace": "fast",
                "duration": 10,
                "signal": {"kind": "step", "amplitude": 0},
                "excitation": {"kind": "prbs", "amplitude": 1.0, "order": 11, "band": 0.05},
                "excitation_at": "input",
                "seed": 1,
            },
        ).json()
        for _ in range(200):
            info = c.get(f"/runs/{run['id']}").json()
            if info["status"] == "finished":
                break
            time.sleep(0.1)
    part = {"source": "run", "run": run["id"], "output": ["theta"]}
    body = {
        "data": part | {"t_to": 4.999},
        "validation": part | {"t_from": 5.0},
        "models": [{"kind": "arx", "na": 4, "nb": 4, "nk": 1}],
    }
    r = _ident(server, body)
    assert r.status_code == 200, r.text[:500]
    d = r.json()["data"]
    assert d["validation"] == "record" and d["estimation"] == 5000 and d["N"] == info["n_samples"]
    assert r.json()["models"][0]["fit"]["validation_one_step"][0] > 90
    bad = body | {"validation": part | {"t_from": 5.0, "t_to": 1.0}}
    _field_error(_ident(server, bad), "validation.t_to", "after t_from")
    bad = body | {"validation": part | {"output": ["nope"]}}
    _field_error(_ident(server, bad), "validation.output", "channels of run")
    bad = body | {"validation": part | {"output": ["alpha"]}}
    _field_error(_ident(server, bad), "validation.output", "the data's: theta")
    bad = body | {"validation": _file(VALIDATION, input=["c1"], output=["c2"])}
    _field_error(_ident(server, bad), "validation.Ts", "0.001")  # a file at 0.08 s
    r = _ident(server, body | {"validation": part | {"run": "nope"}})
    assert r.status_code == 404 and "nope" in r.json()["error"]["message"]


def test_bad_validation_records_get_errors_naming_the_field(server: Server) -> None:
    def ident(validation: dict[str, Any]) -> Any:
        return _ident(server, {"data": _file(ESTIMATION), "validation": validation})

    two_outputs = _file(VALIDATION, output=["c2", "c1"])  # a channel more than the data
    _field_error(ident(two_outputs), "validation.output", "['c2', 'c1']", "the data's: c2")
    one_column = [row.split()[0] for row in VALIDATION]
    _field_error(ident(_file(one_column)), "validation.output", "one of the columns: c1")
    _field_error(ident(_file(VALIDATION, Ts=0.1)), "validation.Ts", "0.1", "0.08 s")
    nan = VALIDATION.copy()
    nan[17] = "nan 4.7"
    _field_error(ident(_file(nan)), "validation row 18", "finite numbers")
    _field_error(ident(_file(VALIDATION) | {"text": ""}), "validation.file.text")
    _field_error(ident(_file(["# no samples"])), "validation", "no rows")
    _field_error(ident(_file(VALIDATION[:1])), "validation", "at least 2 samples")
    huge_value = VALIDATION.copy()
    huge_value[3] = huge_value[3].split()[0] + " 1e300"  # its squares overflow
    _field_error(ident(_file(huge_value)), "validation.c2", "1e+300", "[1e-50, 1e+50]")
    tiny = [f"{float(row.split()[0]) * 1e-60} {row.split()[1]}" for row in ESTIMATION]
    r = _ident(server, {"data": _file(tiny)})
    _field_error(r, "data.c1", "6.41e-60", "or all zero")
    _field_error(ident({"source": "file"}), "validation.file.text")
    # too long: both records together over the samples limit, named before any work
    n = MAX_SAMPLES - len(ESTIMATION) + 1
    message = _field_error(
        ident(_file([], text="1 2\n" * n)), "validation", f"at most {MAX_SAMPLES - 500:,}"
    )
    assert f"{n:,} samples" in message
    # and the body's limit (ELAB_MAX_UPLOAD, 16 MiB) counts both records
    huge = _file([], text="1 2\n" * 4_300_000)
    r = ident(huge)
    assert r.status_code == 413 and "ELAB_MAX_UPLOAD" in r.json()["error"]["message"]
    with server.client() as c:  # the server is fine afterwards
        assert c.get("/plants").status_code == 200
