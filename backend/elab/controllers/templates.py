"""A controller template per plant and format: the plant's predefined controller, filled
in, every field explained (TOML; the other formats hold the same values)."""

from __future__ import annotations

import io
import json
from typing import Any

import numpy as np

from elab.controllers.files import FORMATS, VERSION
from elab.errors import InvalidInput
from elab.laws import PID, ControlLaw, LTIController, OpenLoop, StateFeedback
from elab.plants import Plant


def template(plant: Plant, fmt: str) -> bytes:
    """The template of ``plant``'s controller in ``fmt`` (toml, json, mat or npz)."""
    if fmt not in FORMATS:
        raise InvalidInput("format", fmt, ", ".join(FORMATS))
    fields = law_fields(plant.predefined)
    if fmt == "toml":
        return _toml(plant, fields).encode()
    if fmt == "json":
        body = {"version": VERSION, "plant": plant.id, **fields}
        return (json.dumps(body, indent=2) + "\n").encode()
    arrays = {
        k: (np.asarray(v, dtype=np.float64) if k != "estimate" else v)
        for k, v in fields.items()
        if k != "kind" and v is not None
    }
    buf = io.BytesIO()
    if fmt == "mat":
        import scipy.io

        if "dt" in arrays:
            arrays["Ts"] = arrays.pop("dt")
        scipy.io.savemat(buf, arrays, format="5")
    else:
        np.savez(buf, **{k: np.asarray(v) for k, v in arrays.items()})  # type: ignore[arg-type]
    return buf.getvalue()


def law_fields(law: ControlLaw) -> dict[str, Any]:
    """A law as the fields of a controller file (the inverse of reading one)."""
    if isinstance(law, StateFeedback):
        return {"kind": "state_feedback", "K": list(law.K), "estimate": law.estimate}
    if isinstance(law, PID):
        out: dict[str, Any] = {"kind": "pid", "Kp": law.Kp, "Ki": law.Ki, "Kd": law.Kd, "N": law.N}
        if law.Tt is not None:
            out["Tt"] = law.Tt
        return out
    if isinstance(law, LTIController):
        fields: dict[str, Any] = {"kind": "lti"}
        for name in ("num", "den"):
            if getattr(law, name) is not None:
                fields[name] = list(getattr(law, name))
        for name in ("A", "B", "C", "D"):
            if getattr(law, name) is not None:
                fields[name] = [list(r) for r in getattr(law, name)]
        if law.dt is not None:
            fields["dt"] = law.dt
        return fields
    assert isinstance(law, OpenLoop)
    return {"kind": "open_loop"}


def _toml(plant: Plant, f: dict[str, Any]) -> str:
    states = ", ".join(s.name for s in plant.states)
    head = [
        f"# E-Lab controller for the {plant.name.lower()} ({plant.id}).",
        "# Edit the values, check it offline (elab check this.toml --plant "
        f"{plant.id}), upload it.",
        f"# This template holds the predefined controller: {plant.predefined_design}.",
        "# Units are SI: rad, m, s, V. docs/controllers.md has every field.",
        "",
        f"version = {VERSION}  # the file format's version",
        f'plant = "{plant.id}"  # checked: a file for another plant is refused',
        'name = "my controller"  # shown with your runs',
        "",
    ]
    kind = f["kind"]
    if kind == "state_feedback":
        body = [
            'kind = "state_feedback"  # u = K (x_ref − x̂); also: pid, lti, open_loop',
            "",
            f"# one gain per state, in this order: {states}",
            f"K = [{', '.join(_num(k) for k in f['K'])}]",
            "",
            "# x̂: velocity_filters = positions measured, velocities from band-limited",
            "# differentiators (what the real rig can do); true_state = the simulated state",
            f'estimate = "{f["estimate"]}"',
        ]
    elif kind == "pid":
        out = plant.outputs[plant.reference_output]
        body = [
            f'kind = "pid"  # u = C(s) (r − {out.name}); also: state_feedback, lti, open_loop',
            "",
            "# C(s) = Kp + Ki/s + Kd s / (Tf s + 1), Tf = Kd / (N Kp); Tustin at the run's Ts",
            f"Kp = {_num(f['Kp'])}  # V per {out.unit}",
            f"Ki = {_num(f['Ki'])}  # V per {out.unit}·s",
            f"Kd = {_num(f['Kd'])}  # V·s per {out.unit}",
            f"N = {_num(f['N'])}  # derivative filter: the derivative acts up to N Kp / Kd rad/s",
            "# Tt = 1.0  # anti-windup tracking time (s); default sqrt(Ti Td), or Ti",
        ]
    else:
        body = [f'kind = "{kind}"'] + [
            f"{k} = {json.dumps(v)}" for k, v in f.items() if k != "kind"
        ]
    tail = [
        "",
        "# Other kinds, for reference:",
        '# kind = "lti" with num = [..], den = [..] (descending powers of s, or of z with',
        "#   dt = sample time), or A, B, C, D: any SISO controller on the error r − y",
        '# kind = "open_loop": u = r',
        "",
    ]
    return "\n".join(head + body + tail)


def _num(x: float) -> str:
    return repr(float(x)) if x != int(x) or abs(x) >= 1e15 else str(int(x))
