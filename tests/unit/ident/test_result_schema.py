"""Every model kind's result fits the wire's IdentOut (a parameter the schema does not
take — ARMAX/OE's per-start losses once — is a 500 for the API's user)."""

from __future__ import annotations

import json

import numpy as np

from elab.api.identjson import ident_json
from elab.ident import workflow as wf
from tests.unit.ident.conftest import DRYER


def test_every_kind_of_model_fits_the_wire_schema() -> None:
    raw = np.loadtxt(DRYER)
    from elab.ident import iddata

    z = iddata(raw[:, 1], raw[:, 0], 0.08)
    models = ("arx:2,2,3", "armax:2,2,2,3", "oe:2,2,3", "n4sid:6", "n4sid")
    plan = wf.Plan(models=tuple(wf.parse_model(m) for m in models), arx_search=(range(1, 3),) * 3)
    out = json.loads(ident_json(wf.run(z, plan)))
    assert [m["kind"] for m in out["models"]] == ["arx", "armax", "oe", "n4sid", "n4sid"]
    oe = out["models"][2]["parameters"]
    assert oe["start"] in oe["start_losses"] and oe["loss"] == min(oe["start_losses"].values())
