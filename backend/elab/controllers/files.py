"""Controllers as users write them: TOML, JSON, MATLAB ``.mat`` and NumPy ``.npz`` files,
read into the lab's control laws (:mod:`elab.laws`), and a template of each per plant.

Every format says the same thing (docs/controllers.md):

- ``kind = "state_feedback"``: ``K`` (one gain per plant state), ``estimate``
  (``"velocity_filters"``, what the rig can measure, or ``"true_state"``);
- ``kind = "pid"``: ``Kp``, ``Ki``, ``Kd``, ``N`` (derivative filter), ``Tt``
  (anti-windup tracking time);
- ``kind = "lti"``: a transfer function ``num``, ``den`` or a state space ``A``, ``B``,
  ``C``, ``D`` on the error r − y, continuous (Tustin at the run's sample time) or
  discrete with its sample time ``dt`` (MATLAB's ``Ts``; 0 means continuous); a state
  space may add the reference's own input ``B_r``, ``D_r`` (two degrees of freedom);
- ``kind = "open_loop"``: u = r;
- a Python file (``.py``) defining ``class Controller`` with ``reset(params)`` and
  ``step(t, y, r) -> u``: read here only as far as its syntax; it runs only in the
  sandbox (:mod:`elab.controllers.sandbox`).

A ``.mat`` or ``.npz`` file holds plain matrices named as above; the kind follows from
which are there. Nothing is ever unpickled, and every size is bounded before data are
read: a file of at most :data:`MAX_BYTES`, at most :data:`MAX_ORDER` controller states or
coefficients, a ``.npz`` whose members together expand to at most :data:`MAX_EXPANDED`.
"""

from __future__ import annotations

import ast
import io
import json
import math
import re
import tomllib
import zipfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from elab.errors import InvalidInput
from elab.laws import PID, CodeController, ControlLaw, LTIController, OpenLoop, StateFeedback
from elab.plants import Plant

FORMATS = ("toml", "json", "mat", "npz", "py")
VERSION = 1
MAX_BYTES = 64 * 1024
MAX_ORDER = 20  # controller states, or polynomial coefficients
MAX_EXPANDED = 1 << 20  # bytes a .npz may expand to
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
_MAT_FIX = "save -v7 ctrl.mat A B C D Ts  (or K, or Kp Ki Kd, or num den Ts)"


@dataclass(frozen=True)
class Controller:
    """A controller read from a file: its law and what the file said about itself."""

    law: ControlLaw
    format: str
    name: str = ""
    plant: str | None = None  # the plant the file names, if it does


def read_controller(data: bytes, fmt: str, plant: Plant) -> Controller:
    """Read a controller file for ``plant``. :class:`InvalidInput` names what is wrong:
    the line and column of a syntax error, an unknown field and the allowed ones, a
    dimension against the plant, a non-finite number."""
    if fmt not in FORMATS:
        raise InvalidInput("format", fmt, ", ".join(FORMATS))
    if len(data) > MAX_BYTES:
        raise InvalidInput("file", f"{len(data)} bytes", f"a file of at most {MAX_BYTES} bytes")
    if not data:
        raise InvalidInput("file", "an empty file", f"a {fmt} controller file")
    if fmt == "py":
        return _python(data)
    if fmt in ("toml", "json"):
        fields = _text_fields(data, fmt)
    elif fmt == "mat":
        fields = _mat_fields(data)
    else:
        fields = _npz_fields(data)
    return _controller(fields, fmt, plant)


def law_from_fields(fields: Mapping[str, Any], plant: Plant) -> ControlLaw:
    """The law of a controller file's fields (as :func:`elab.controllers.law_fields`
    writes them; how a stored controller comes back)."""
    return _controller({"version": VERSION, **fields}, "stored", plant).law


def format_of(filename: str) -> str:
    """The format of a file from its name's extension."""
    ext = filename.rsplit(".", 1)[-1].lower() if "." in filename else ""
    if ext not in FORMATS:
        raise InvalidInput(
            "file", filename, "a name ending in " + ", ".join("." + f for f in FORMATS)
        )
    return ext


# -- Python ---------------------------------------------------------------------------
def _python(data: bytes, filename: str = "controller.py") -> Controller:
    """A Python controller's source, parsed (never run here): its syntax, with line and
    column, and a top-level ``class Controller`` with a ``step`` method."""
    text = _utf8(data)
    if "\0" in text:
        raise InvalidInput("file", f"a NUL character at offset {text.index(chr(0))}", "text")
    try:
        tree = ast.parse(text, filename)
    except SyntaxError as exc:
        raise InvalidInput(
            "file",
            f"line {exc.lineno}, column {exc.offset}: {exc.msg}",
            "valid Python 3 source",
        ) from None
    except (RecursionError, MemoryError):
        raise InvalidInput("file", "nested too deeply", "plain Python source") from None
    classes = [n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Controller"]
    if not classes:
        raise InvalidInput(
            "file", "no top-level class Controller", "a module defining class Controller"
        )
    methods = {n.name for n in classes[-1].body if isinstance(n, ast.FunctionDef)}
    if "step" not in methods:
        raise InvalidInput(
            "Controller",
            f"methods {', '.join(sorted(methods)) or 'none'}",
            "a class with step(self, t, y, r) (and optionally reset(self, params))",
        )
    doc = ast.get_docstring(tree) or ""
    name = doc.strip().splitlines()[0][:80] if doc.strip() else ""
    return Controller(CodeController(text, filename), "py", name)


def _utf8(data: bytes) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InvalidInput(
            "file", f"byte {exc.start}: {data[exc.start : exc.start + 4]!r}", "UTF-8 text"
        ) from None


# -- text formats ---------------------------------------------------------------------
def _text_fields(data: bytes, fmt: str) -> dict[str, Any]:
    text = _utf8(data)
    try:
        parsed = tomllib.loads(text) if fmt == "toml" else json.loads(text, parse_constant=_no_nan)
    except tomllib.TOMLDecodeError as exc:
        raise InvalidInput("file", _where(str(exc), text), "valid TOML") from None
    except json.JSONDecodeError as exc:
        raise InvalidInput(
            "file", f"line {exc.lineno}, column {exc.colno}: {exc.msg}", "valid JSON"
        ) from None
    except RecursionError:
        raise InvalidInput("file", "nested too deeply", f"a flat {fmt} file") from None
    except ValueError as exc:  # an integer of more digits than Python converts (4,300)
        raise InvalidInput("file", str(exc)[:80], "numbers of at most 4,300 digits") from None
    if not isinstance(parsed, dict):
        raise InvalidInput("file", type(parsed).__name__, "a table of fields (kind = …)")
    if "version" not in parsed:
        raise InvalidInput("version", None, f"version = {VERSION} (the file format's version)")
    if parsed["version"] != VERSION or isinstance(parsed["version"], bool):
        raise InvalidInput("version", parsed["version"], f"{VERSION}")
    return parsed


def _no_nan(token: str) -> Any:
    raise InvalidInput("file", token, "finite numbers (JSON has no NaN or Infinity)")


def _where(message: str, text: str) -> str:
    """tomllib's message with its position first: 'line 3, column 7: …'."""
    m = re.search(r"\(at line (\d+), column (\d+)\)", message)
    if not m:
        end = message.replace("(at end of document)", "").strip()
        return f"line {text.count(chr(10)) + 1}, the end of the file: {end}"
    return f"line {m.group(1)}, column {m.group(2)}: {message[: m.start()].strip()}"


# -- binary formats -------------------------------------------------------------------
def _mat_fields(data: bytes) -> dict[str, Any]:
    import scipy.io

    if data[:128].find(b"MATLAB 7.3") >= 0 or data[512:516] == b"\x89HDF":
        raise InvalidInput(
            "file", "a MATLAB v7.3 (HDF5) file", f"a v7 or older .mat file: {_MAT_FIX}"
        )
    _mat_sizes(data)
    try:
        raw = scipy.io.loadmat(io.BytesIO(data), squeeze_me=False, struct_as_record=True)
    except Exception as exc:  # scipy raises many kinds for a damaged file
        raise InvalidInput(
            "file", f"not a readable .mat file ({exc})", f"a v4-v7 .mat file: {_MAT_FIX}"
        ) from None
    out: dict[str, Any] = {}
    for name, value in raw.items():
        if name.startswith("__"):
            continue
        out[name] = _mat_value(name, value)
    return _binary_kind(out)


_MAT_NUMERIC = frozenset(
    {"double", "single", "logical", "char"}
    | {f"{sign}int{bits}" for sign in ("", "u") for bits in (8, 16, 32, 64)}
)


def _mat_sizes(data: bytes) -> None:
    """Refuse a .mat file whose variables, as its headers declare them, are not plain
    matrices or would expand past :data:`MAX_EXPANDED` bytes as float64, before any of
    them is decompressed (issue 24: a 58 KB file declaring 60 M elements took the server
    from 237 MB to 3 GB while it was read)."""
    import scipy.io

    try:
        variables = scipy.io.whosmat(io.BytesIO(data))
    except Exception as exc:  # scipy raises many kinds for a damaged file
        raise InvalidInput(
            "file", f"not a readable .mat file ({exc})", f"a v4-v7 .mat file: {_MAT_FIX}"
        ) from None
    if len(variables) > 16:
        raise InvalidInput("file", f"{len(variables)} variables", "at most 16 matrices")
    total = 0
    for name, shape, kind in variables:
        if kind not in _MAT_NUMERIC:
            raise InvalidInput(
                name,
                f"a MATLAB {kind}",
                f"plain numeric matrices (no ss/tf objects, structs or cells): {_MAT_FIX}",
            )
        total += math.prod(shape) * 8
        if total > MAX_EXPANDED:
            raise InvalidInput(
                name,
                f"a {'×'.join(map(str, shape))} matrix",
                f"matrices of at most {MAX_EXPANDED} bytes together as float64",
            )


def _mat_value(name: str, value: Any) -> Any:
    if isinstance(value, np.ndarray) and value.dtype.kind in "U":
        return "".join(value.ravel().tolist())
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "fiub":
        raise InvalidInput(
            name,
            f"a MATLAB {type(value).__name__ if not isinstance(value, np.ndarray) else 'object'}",
            f"plain numeric matrices (no ss/tf objects, structs or cells): {_MAT_FIX}",
        )
    return value.astype(np.float64)


def _npz_fields(data: bytes) -> dict[str, Any]:
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
        members = archive.infolist()
    except zipfile.BadZipFile:
        raise InvalidInput("file", "not a zip archive", "an .npz file (numpy.savez)") from None
    if len(members) > 16 or sum(m.file_size for m in members) > MAX_EXPANDED:
        raise InvalidInput(
            "file",
            f"{len(members)} members expanding to {sum(m.file_size for m in members)} bytes",
            f"at most 16 arrays and {MAX_EXPANDED} bytes expanded",
        )
    try:
        npz = np.load(io.BytesIO(data), allow_pickle=False)
        out = {name: npz[name] for name in npz.files}
    except ValueError as exc:  # object arrays need pickle: refused
        raise InvalidInput(
            "file", f"{exc}", "numeric arrays (pickled objects are never loaded)"
        ) from None
    except Exception as exc:
        raise InvalidInput(
            "file", f"not a readable .npz ({exc})", "an .npz file (numpy.savez)"
        ) from None
    for name, value in out.items():
        if value.dtype.kind == "U":
            out[name] = str(value.item()) if value.size == 1 else value
        elif value.dtype.kind not in "fiub":
            raise InvalidInput(name, str(value.dtype), "numeric arrays")
        else:
            out[name] = value.astype(np.float64)
    return _binary_kind(out)


def _binary_kind(fields: dict[str, Any]) -> dict[str, Any]:
    """The kind a set of matrices means (the names say it); ``Ts`` is MATLAB's ``dt``."""
    out: dict[str, Any] = {k: _plain(v) for k, v in fields.items()}
    if "Ts" in out:
        ts = out.pop("Ts")
        out["dt"] = None if ts in (0, 0.0, -1, -1.0) else ts
    names = set(out)
    if "kind" in out:
        return {"version": VERSION, **out}
    for kind, marker in (("state_feedback", {"K"}), ("pid", {"Kp"}), ("lti", {"num", "A"})):
        if names & marker:
            return {"version": VERSION, "kind": kind, **out}
    raise InvalidInput(
        "file",
        ", ".join(sorted(names)) or "no matrices",
        "K (state feedback), Kp/Ki/Kd (PID), num and den, or A, B, C, D (with Ts)",
    )


def _plain(value: Any) -> Any:
    """A matrix as nested lists (a 1×1 one as a number), as the text formats give them."""
    if isinstance(value, np.ndarray):
        if value.size == 1:
            return float(value.ravel()[0])
        return value.tolist()
    return value


# -- fields to a law ------------------------------------------------------------------
def _controller(fields: Mapping[str, Any], fmt: str, plant: Plant) -> Controller:
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
