"""A controller file's fields, whatever its format, checked and made into a control law
(:mod:`elab.laws`): the fields each kind allows, dimensions against the plant, finite
numbers, at most :data:`~elab.controllers.file_format.MAX_ORDER` states or
coefficients."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from elab.controllers.file_format import MAX_ORDER, Controller
from elab.errors import InvalidInput
from elab.laws import PID, ControlLaw, LTIController, OpenLoop, StateFeedback
from elab.plants import Plant

_FIELDS = {
    "state_feedback": ("K", "estimate", "Nr", "L", "observer_poles"),
    "pid": ("Kp", "Ki", "Kd", "N", "Tt", "b", "c"),
    "lti": ("num", "den", "A", "B", "C", "D", "dt", "ff_num", "ff_den", "B_r", "D_r"),
    "chain": ("blocks", "dt", "ff_num", "ff_den"),
    "open_loop": (),
}
MAX_BLOCKS = 8
_BLOCK_FIELDS = {"pid": ("Kp", "Ki", "Kd", "N"), "lti": ("num", "den", "A", "B", "C", "D")}
_COMMON = ("version", "kind", "plant", "name")


def controller_of_fields(fields: Mapping[str, Any], fmt: str, plant: Plant) -> Controller:
    kind = fields.get("kind")
    if kind not in _FIELDS:
        raise InvalidInput("kind", kind, ", ".join(_FIELDS))
    allowed = _COMMON + _FIELDS[kind]
    for key in fields:
        if key not in allowed:
            raise InvalidInput(
                key, fields[key], f"a field of a {kind} controller: {', '.join(allowed)}"
            )
    named = fields.get("plant")
    if named is not None and named != plant.id:
        raise InvalidInput("plant", named, f"{plant.id} (the file is for another plant)")
    name = fields.get("name", "")
    if not isinstance(name, str) or len(name) > 80:
        raise InvalidInput("name", name, "a text of at most 80 characters")
    law = _LAWS[kind](fields, plant)
    return Controller(law, fmt, name, named)


def _state_feedback(f: Mapping[str, Any], plant: Plant) -> StateFeedback:
    K = _vector("K", f.get("K"), plant.nx, plant.nx)
    estimate = f.get("estimate", "velocity_filters")
    if estimate not in ("velocity_filters", "true_state", "observer"):
        raise InvalidInput("estimate", estimate, "velocity_filters, true_state or observer")
    if len(K) != plant.nx:
        states = ", ".join(s.name for s in plant.states)
        raise InvalidInput("K", list(K), f"{plant.nx} gains, one per state of {plant.id}: {states}")
    Nr = None if f.get("Nr") is None else _number("Nr", f.get("Nr"))
    L = poles = None
    if estimate == "observer":
        if ("L" in f) == ("observer_poles" in f):
            raise InvalidInput(
                "estimate",
                "observer",
                f"an observer with either L ({plant.nx}×{plant.ny}: a row per state, a "
                f"column per output) or observer_poles ({plant.nx} poles)",
            )
        if "L" in f:
            L = _matrix("L", f["L"])
            if (len(L), len(L[0])) != (plant.nx, plant.ny):
                raise InvalidInput(
                    "L", f"{len(L)}×{len(L[0])}", f"{plant.nx}×{plant.ny} (states × outputs)"
                )
        else:
            poles = _poles("observer_poles", f["observer_poles"], plant.nx)
    elif "L" in f or "observer_poles" in f:
        raise InvalidInput(
            "L" if "L" in f else "observer_poles", "given", 'estimate = "observer" with it'
        )
    return StateFeedback(K, estimate, Nr, L, poles)


def _poles(field: str, value: Any, n: int) -> tuple[complex, ...]:
    """``n`` poles: numbers, or [re, im] pairs for complex ones (conjugates both given)."""
    if not isinstance(value, list) or len(value) != n:
        raise InvalidInput(field, value, f"{n} poles: numbers, or [re, im] for complex ones")
    out = []
    for i, v in enumerate(value):
        if isinstance(v, list):
            if len(v) != 2:
                raise InvalidInput(f"{field}[{i}]", v, "[re, im]")
            out.append(complex(_number(f"{field}[{i}]", v[0]), _number(f"{field}[{i}]", v[1])))
        else:
            out.append(complex(_number(f"{field}[{i}]", v)))
    return tuple(out)


def _pid(f: Mapping[str, Any], plant: Plant) -> PID:
    Tt = f.get("Tt")
    return PID(
        _number("Kp", f.get("Kp")),
        _number("Ki", f.get("Ki", 0.0)),
        _number("Kd", f.get("Kd", 0.0)),
        _number("N", f.get("N", 10.0), positive=True),
        None if Tt is None else _number("Tt", Tt, positive=True),
        _number("b", f.get("b", 1.0)),
        _number("c", f.get("c", 1.0)),
    )


def _feedforward(f: Mapping[str, Any]) -> dict[str, tuple[float, ...]]:
    if "ff_num" not in f and "ff_den" not in f:
        return {}
    num = _vector("ff_num", f.get("ff_num"), 1, MAX_ORDER)
    den = _vector("ff_den", f.get("ff_den"), 1, MAX_ORDER)
    if den[0] == 0:
        raise InvalidInput("ff_den", list(den), "a leading coefficient that is not zero")
    if len(num) > len(den):
        raise InvalidInput("ff_num", list(num), f"at most {len(den)} coefficients (proper)")
    return {"ff_num": num, "ff_den": den}


def _chain(f: Mapping[str, Any], plant: Plant) -> LTIController:
    """Blocks in series on the error (each a ``pid`` or an ``lti``, all continuous or all
    at one sample time ``dt``), as one LTI law (python-control ``series``). A PID in a
    chain has no anti-windup (it is one linear block among others)."""
    import control as ct

    from elab.design.realise import lti_ss, pid_tf

    blocks = f.get("blocks")
    if not isinstance(blocks, list) or not 1 <= len(blocks) <= MAX_BLOCKS:
        raise InvalidInput(
            "blocks", blocks, f"1 to {MAX_BLOCKS} blocks ([[blocks]] tables, in signal order)"
        )
    dt = f.get("dt")
    dt = None if dt is None else _number("dt", dt, positive=True)
    total: Any = None
    for i, block in enumerate(blocks):
        if not isinstance(block, dict) or block.get("kind") not in ("pid", "lti"):
            raise InvalidInput(f"blocks[{i}].kind", _kind_of(block), "pid or lti")
        # no setpoint weights or anti-windup in a chain: its blocks act on the error alone
        allowed = ("kind", *_BLOCK_FIELDS[block["kind"]])
        for key in block:
            if key not in allowed:
                raise InvalidInput(
                    f"blocks[{i}].{key}",
                    block[key],
                    "a field of the block: "
                    + ", ".join(allowed)
                    + " (the chain's dt applies to every block)",
                )
        try:
            if block["kind"] == "pid":
                if dt is not None:
                    raise InvalidInput(f"blocks[{i}]", "pid", "lti blocks in a discrete chain")
                part: Any = ct.ss(pid_tf(_pid(block, plant)))
            else:
                part = lti_ss(_lti({**block, "dt": dt}, plant))
        except InvalidInput as exc:
            if exc.field.startswith("blocks["):
                raise
            raise InvalidInput(
                f"blocks[{i}].{exc.field.removeprefix('controller.')}", exc.value, exc.allowed
            ) from None
        total = part if total is None else ct.series(total, part)
    if total.nstates > MAX_ORDER:
        raise InvalidInput("blocks", f"{total.nstates} states", f"at most {MAX_ORDER} together")
    n = total.nstates
    ff = _feedforward(f)

    def rows(m: Any) -> tuple[tuple[float, ...], ...]:
        return tuple(tuple(float(x) for x in r) for r in np.asarray(m, dtype=np.float64))

    return LTIController(
        A=rows(np.reshape(total.A, (n, n))),
        B=rows(np.reshape(total.B, (n, 1))),
        C=rows(np.reshape(total.C, (1, n))),
        D=rows(np.reshape(total.D, (1, 1))),
        dt=dt,
        ff_num=ff.get("ff_num"),
        ff_den=ff.get("ff_den"),
    )


def _kind_of(block: Any) -> Any:
    return block.get("kind") if isinstance(block, dict) else type(block).__name__


def _lti(f: Mapping[str, Any], plant: Plant) -> LTIController:
    dt = f.get("dt")
    dt = None if dt is None else _number("dt", dt, positive=True)
    tf = "num" in f or "den" in f
    ss = any(k in f for k in ("A", "B", "C", "D", "B_r", "D_r"))
    if tf == ss:
        raise InvalidInput(
            "kind", "lti", "either num and den, or A, B, C, D (not both, not neither)"
        )
    if tf:
        num = _vector("num", f.get("num"), 1, MAX_ORDER)
        den = _vector("den", f.get("den"), 1, MAX_ORDER)
        if den[0] == 0:
            raise InvalidInput("den", list(den), "a leading coefficient that is not zero")
        if len(num) > len(den):
            raise InvalidInput(
                "num", list(num), f"at most {len(den)} coefficients (a proper controller)"
            )
        ff = _feedforward(f)
        return LTIController(
            num=num, den=den, dt=dt, ff_num=ff.get("ff_num"), ff_den=ff.get("ff_den")
        )
    A = _matrix("A", f.get("A"))
    n = len(A)
    if any(len(row) != n for row in A) or n > MAX_ORDER:
        raise InvalidInput("A", "…", f"a square matrix of at most {MAX_ORDER} rows")
    B, C, D = _matrix("B", f.get("B")), _matrix("C", f.get("C")), _matrix("D", f.get("D", [[0.0]]))
    own = {k: _matrix(k, f[k]) for k in ("B_r", "D_r") if k in f}  # the reference's input
    shapes = {"B": (B, (n, 1)), "C": (C, (1, n)), "D": (D, (1, 1))}
    shapes |= {k: (v, (n, 1) if k == "B_r" else (1, 1)) for k, v in own.items()}
    for name, (m, shape) in shapes.items():
        if (len(m), len(m[0]) if m else 0) != shape:
            raise InvalidInput(
                name,
                f"{len(m)}×{len(m[0]) if m else 0}",
                f"{shape[0]}×{shape[1]} (SISO, {n} states)",
            )
    ff = _feedforward(f)
    return LTIController(
        A=A,
        B=B,
        C=C,
        D=D,
        dt=dt,
        ff_num=ff.get("ff_num"),
        ff_den=ff.get("ff_den"),
        B_r=own.get("B_r"),
        D_r=own.get("D_r"),
    )


def _open_loop(f: Mapping[str, Any], plant: Plant) -> OpenLoop:
    return OpenLoop()


_LAWS: dict[str, Callable[[Mapping[str, Any], Plant], ControlLaw]] = {
    "state_feedback": _state_feedback,
    "pid": _pid,
    "lti": _lti,
    "chain": _chain,
    "open_loop": _open_loop,
}


def _number(field: str, value: Any, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidInput(field, value, "a number")
    try:
        x = float(value)
    except OverflowError:  # an integer past 1.8e308
        x = math.inf
    if not math.isfinite(x) or (positive and x <= 0):
        raise InvalidInput(
            field, value, "a positive finite number" if positive else "a finite number"
        )
    return x


def _vector(field: str, value: Any, lo: int, hi: int) -> tuple[float, ...]:
    if isinstance(value, int | float) and not isinstance(value, bool):
        value = [value]
    if isinstance(value, list) and value and all(isinstance(r, list) for r in value):
        if len(value) == 1:  # a row vector, as MATLAB writes one
            value = value[0]
        elif all(len(r) == 1 for r in value):  # a column vector
            value = [r[0] for r in value]
    if not isinstance(value, list) or not lo <= len(value) <= hi:
        raise InvalidInput(
            field, value, f"a list of {lo}..{hi} numbers" if lo != hi else f"a list of {lo} numbers"
        )
    return tuple(_number(f"{field}.{i}", v) for i, v in enumerate(value))


def _matrix(field: str, value: Any) -> tuple[tuple[float, ...], ...]:
    if isinstance(value, int | float) and not isinstance(value, bool):
        value = [[value]]
    if not isinstance(value, list) or not value or len(value) > MAX_ORDER:
        raise InvalidInput(field, value, f"a matrix: a list of 1..{MAX_ORDER} rows")
    rows = [v if isinstance(v, list) else [v] for v in value]
    if len({len(r) for r in rows}) != 1 or len(rows[0]) > MAX_ORDER:
        raise InvalidInput(field, value, f"rows of equal length, at most {MAX_ORDER}")
    return tuple(
        tuple(_number(f"{field}.{i}.{j}", x) for j, x in enumerate(r)) for i, r in enumerate(rows)
    )
