"""A controller template per plant and format: the plant's predefined controller, filled
in, every field explained (TOML and Python; the other formats hold the same values)."""

from __future__ import annotations

import io
import json
from typing import Any, assert_never

import numpy as np

from elab.controllers.file_format import FORMATS, VERSION
from elab.design.realise import pid_filter_time, pid_tracking_time
from elab.errors import InvalidInput
from elab.laws import PID, CodeController, ControlLaw, LTIController, OpenLoop, StateFeedback
from elab.plants import Plant


def template(plant: Plant, fmt: str) -> bytes:
    """The template of ``plant``'s controller in ``fmt`` (toml, json, mat, npz or py)."""
    return law_file(plant, plant.predefined, fmt)


def law_file(plant: Plant, law: ControlLaw, fmt: str, name: str | None = None) -> bytes:
    """``law`` for ``plant`` as a controller file in ``fmt`` (toml, json, mat, npz or py),
    which reads back as the same law (``name``: the file's, in toml and json)."""
    if fmt not in FORMATS:
        raise InvalidInput("format", fmt, ", ".join(FORMATS))
    if fmt == "py":
        return python_source(plant, law).encode()
    fields = law_fields(law)
    if fmt == "toml":
        return _toml(plant, fields, None if law == plant.predefined else name or "").encode()
    if fmt == "json":
        body = {"version": VERSION, "plant": plant.id, **({"name": name} if name else {}), **fields}
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
    """A law as the fields of a controller file (the inverse of reading one; a Python
    controller's fields say only its file name: its source is the file)."""
    match law:
        case CodeController():
            return {"kind": "python", "file": law.name}
        case StateFeedback():
            sf: dict[str, Any] = {
                "kind": "state_feedback",
                "K": list(law.K),
                "estimate": law.estimate,
            }
            if law.Nr is not None:
                sf["Nr"] = law.Nr
            if law.L is not None:
                sf["L"] = [list(r) for r in law.L]
            if law.observer_poles is not None:
                sf["observer_poles"] = [
                    p.real if p.imag == 0 else [p.real, p.imag]
                    for p in (complex(z) for z in law.observer_poles)
                ]
            return sf
        case PID():
            out: dict[str, Any] = {
                "kind": "pid",
                "Kp": law.Kp,
                "Ki": law.Ki,
                "Kd": law.Kd,
                "N": law.N,
            }
            if law.Tt is not None:
                out["Tt"] = law.Tt
            for weight in ("b", "c"):
                if getattr(law, weight) != 1.0:
                    out[weight] = getattr(law, weight)
            return out
        case LTIController():
            fields: dict[str, Any] = {"kind": "lti"}
            for name in ("num", "den"):
                if getattr(law, name) is not None:
                    fields[name] = list(getattr(law, name))
            for name in ("A", "B", "C", "D", "B_r", "D_r"):
                if getattr(law, name) is not None:
                    fields[name] = [list(r) for r in getattr(law, name)]
            if law.dt is not None:
                fields["dt"] = law.dt
            if law.ff_num is not None and law.ff_den is not None:
                fields["ff_num"], fields["ff_den"] = list(law.ff_num), list(law.ff_den)
            return fields
        case OpenLoop():
            return {"kind": "open_loop"}
        case _:
            assert_never(law)


def _toml(plant: Plant, f: dict[str, Any], name: str | None = None) -> str:
    """The fields as TOML with comments; ``name`` None: the predefined controller's
    template, else a designed controller of that name."""
    states = ", ".join(s.name for s in plant.states)
    held = (
        f"This template holds the predefined controller: {plant.predefined_design}."
        if name is None
        else "This file holds a controller designed in E-Lab."
    )
    head = [
        f"# E-Lab controller for the {plant.name.lower()} ({plant.id}).",
        "# Edit the values, check it offline (elab check this.toml --plant "
        f"{plant.id}), upload it.",
        f"# {held}",
        "# Units are SI: rad, m, s, V. docs/controllers.md has every field.",
        "",
        f"version = {VERSION}  # the file format's version",
        f'plant = "{plant.id}"  # checked: a file for another plant is refused',
        f"name = {json.dumps(name or 'my controller', ensure_ascii=False)}  # shown with your runs",
        "",
    ]
    kind = f["kind"]
    if kind == "state_feedback":
        body = [
            'kind = "state_feedback"  # u = K (x_ref − x̂); also: pid, lti, chain, open_loop',
            "",
            f"# one gain per state, in this order: {states}",
            f"K = [{', '.join(_num(k) for k in f['K'])}]",
            "",
            "# x̂: velocity_filters = positions measured, velocities from band-limited",
            "# differentiators (what the real rig can do); true_state = the simulated state;",
            "# observer = a Luenberger observer on the model, with L or observer_poles:",
            f'#   estimate = "observer"; observer_poles = [{_example_poles(plant.nx)}]',
            "#   (complex ones as [re, im] pairs), or L = a row per state, a column per output",
            f'estimate = "{f["estimate"]}"',
            "",
            "# Nr = 20.0  # reference gain: u = Nr r − K x̂ (default: the reference state's gain)",
        ]
    elif kind == "pid":
        out = plant.outputs[plant.reference_output]
        body = [
            f'kind = "pid"  # u = C(s) (r − {out.name}); also: state_feedback, lti, chain',
            "",
            "# C(s) = Kp + Ki/s + Kd s / (Tf s + 1), Tf = Kd / (N Kp); Tustin at the run's Ts",
            f"Kp = {_num(f['Kp'])}  # V per {out.unit}",
            f"Ki = {_num(f['Ki'])}  # V per {out.unit}·s",
            f"Kd = {_num(f['Kd'])}  # V·s per {out.unit}",
            f"N = {_num(f['N'])}  # derivative filter: the derivative acts up to N Kp / Kd rad/s",
            "# Tt = 1.0  # anti-windup tracking time (s); default sqrt(Ti Td), or Ti",
            "# setpoint weights: u = Kp (b r − y) + Ki ∫(r − y) + D(s) (c r − y)",
            "# b = 1.0",
            "# c = 1.0",
        ]
    else:
        body = [f'kind = "{kind}"'] + [
            f"{k} = {json.dumps(v)}" for k, v in f.items() if k != "kind"
        ]
    tail = [
        "",
        "# Other kinds, for reference:",
        '# kind = "lti" with num = [..], den = [..] (descending powers of s, or of z with',
        "#   dt = sample time), or A, B, C, D: any SISO controller on the error r − y;",
        "#   ff_num, ff_den: a feed-forward from r to u, added",
        '# kind = "chain": blocks in series on the error, each a [[blocks]] table with',
        '#   kind = "pid" or "lti" and its fields (dt once, for the whole chain)',
        '# kind = "open_loop": u = r',
        "",
    ]
    return "\n".join(head + body + tail)


def _example_poles(n: int) -> str:
    return ", ".join(str(-40 - 5 * i) for i in range(n))


def _num(x: float) -> str:
    return repr(float(x)) if x != int(x) or abs(x) >= 1e15 else str(int(x))


# -- Python ---------------------------------------------------------------------------
_PY_HEAD = '''"""{title}

E-Lab runs this file in a sandbox: reset(params) once before the run, then
step(t, y, r) once per sample (every {Ts:g} s), which returns u in volts.

- t: the sample's time (s); r: the reference of {ref} ({ref_unit});
- y: the measured outputs in absolute units, as the rig gives them:
  {outputs};
- params: "Ts" (s), "u_max" (V; the actuator limit, applied to your u after
  step), "outputs", "units", "y_op" (the outputs at the operating point),
  "reference_output" (the index of {ref} in y), "plant".

Only numpy, math, cmath, collections, dataclasses, functools and itertools can
be imported; nothing can reach files, the network or other processes. A step
has 0.5 ms: a late answer holds the last u, and 10 late in a row end the run.
Check it offline: elab check this.py --plant {plant}; elab simulate {plant}
--controller this.py.
"""

import numpy as np
'''


def python_source(plant: Plant, law: ControlLaw) -> str:
    """``law`` for ``plant`` written as a Python controller: the same arithmetic as the
    declarative law's discrete controller (Tustin at the run's sample time, the PID's
    back-calculation anti-windup), so a run of either gives the same samples up to
    rounding. State feedback and PID are written so; state feedback on the true state
    becomes state feedback on velocity filters (code sees only the measured outputs)."""
    out = plant.outputs[plant.reference_output]
    title = f"E-Lab controller for the {plant.name.lower()} ({plant.id}): {_describe(plant, law)}"
    head = _PY_HEAD.format(
        title=title,
        Ts=plant.Ts,
        ref=out.name,
        ref_unit=out.unit,
        outputs=", ".join(f"{i}: {o.name} ({o.unit})" for i, o in enumerate(plant.outputs)),
        plant=plant.id,
    )
    match law:
        case StateFeedback() if plant.velocity_filters:
            return head + _py_state_feedback(plant, law)
        case PID():
            return head + _py_pid(plant, law)
    raise InvalidInput(
        "law",
        type(law).__name__,
        "state feedback on velocity filters or a PID (the laws written as Python templates)",
    )


def _describe(plant: Plant, law: ControlLaw) -> str:
    if law == plant.predefined:
        on = "" if getattr(law, "estimate", "") != "true_state" else ", on velocity filters"
        return f"the predefined controller ({plant.predefined_design}{on})"
    match law:
        case StateFeedback():
            return "state feedback"
        case _:
            return "a PID"


def _py_state_feedback(plant: Plant, law: StateFeedback) -> str:
    filters = {f.state: f for f in plant.velocity_filters}
    measured = {}
    for j in range(plant.nx):
        if j in filters:
            continue
        unit = np.eye(plant.nx)[j]
        found = [o for o in range(plant.ny) if np.array_equal(plant.C[o], unit)]
        if not found:
            raise InvalidInput("law", "velocity_filters", f"state {j} measured by an output")
        measured[j] = found[0]
    states = ", ".join(f"{i}: {st.name}" for i, st in enumerate(plant.states))
    rows = ",\n".join(
        f"    ({f.state}, {f.output}, {_num(f.omega_c)})" for f in plant.velocity_filters
    )
    return f"""
# u = K (x_ref − x̂), x_ref = r on state {plant.reference_state}; states: {states}
K = np.array([{", ".join(_num(k) for k in law.K)}])
REFERENCE_STATE = {plant.reference_state}
# states measured directly: state -> output
MEASURED = {{{", ".join(f"{j}: {o}" for j, o in measured.items())}}}
# velocities from band-limited differentiators wc s / (s + wc) of an output:
# (state, output, wc in rad/s)
FILTERS = [
{rows},
]


class Controller:
    def reset(self, params):
        self.Ts = params["Ts"]
        self.y_op = np.array(params["y_op"])
        self.low = np.zeros(len(FILTERS))  # each filter's low-passed output
        self.last = np.zeros(len(FILTERS))  # and its input at the last sample

    def step(self, t, y, r):
        dy = y - self.y_op  # deviations from the operating point
        x = np.zeros(len(K))
        for state, output in MEASURED.items():
            x[state] = dy[output]
        for i, (state, output, wc) in enumerate(FILTERS):
            # Tustin: low = wc / (s + wc) dy, velocity = wc (dy - low)
            a = wc * self.Ts / 2
            self.low[i] = ((1 - a) * self.low[i] + a * (dy[output] + self.last[i])) / (1 + a)
            self.last[i] = dy[output]
            x[state] = wc * (dy[output] - self.low[i])
        x_ref = np.zeros(len(K))
        x_ref[REFERENCE_STATE] = r
        return float(K @ (x_ref - x))
"""


def _py_pid(plant: Plant, law: PID) -> str:
    out = plant.outputs[plant.reference_output]
    return f"""
# u = Kp e + Ki ∫e + Kd s / (Tf s + 1) e on e = r − {out.name}, Tustin at Ts
Kp = {_num(law.Kp)}  # V per {out.unit}
Ki = {_num(law.Ki)}  # V per {out.unit}·s
Kd = {_num(law.Kd)}  # V·s per {out.unit}
Tf = {_num(pid_filter_time(law))}  # s, the derivative's filter (Kd / (N Kp), N = {_num(law.N)})
Tt = {_num(pid_tracking_time(law))}  # s, anti-windup tracking time
REFERENCE_OUTPUT = {plant.reference_output}


class Controller:
    def reset(self, params):
        self.Ts = params["Ts"]
        self.u_max = params["u_max"] or float("inf")
        self.y_op = params["y_op"][REFERENCE_OUTPUT]
        self.integral = 0.0  # Ts times the errors so far (trapezoid: + Ts/2 e now)
        self.derivative = 0.0
        self.last_e = 0.0

    def step(self, t, y, r):
        Ts = self.Ts
        e = r - (y[REFERENCE_OUTPUT] - self.y_op)
        self.derivative = (
            (2 * Tf - Ts) * self.derivative + 2 * Kd * (e - self.last_e)
        ) / (2 * Tf + Ts)
        self.last_e = e
        v = Kp * e + Ki * (self.integral + Ts / 2 * e) + self.derivative
        u = min(max(v, -self.u_max), self.u_max)  # what the actuator applies
        # back-calculation anti-windup: the integral follows what was applied
        if Ki != 0:
            self.integral += Ts * e + Ts / (Ki * Tt) * (u - v)
        return v
"""
