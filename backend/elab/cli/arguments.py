"""Command-line text as the lab's values: quantities with units (``30deg``), vectors,
complex poles, control laws (``pid:2,1,0.1``) and the controller files a command names."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from elab.errors import InvalidInput
from elab.laws import PID, CodeController, ControlLaw, OpenLoop, StateFeedback
from elab.plants import Plant

UNITS = {"deg": math.pi / 180, "rad": 1.0, "mm": 1e-3, "m": 1.0, "V": 1.0, "s": 1.0, "Hz": 1.0}


def parse_quantity(text: str, field: str = "value") -> float:
    """``"30deg"`` → 0.5236 (SI); a plain number is taken as SI."""
    for suffix, factor in sorted(UNITS.items(), key=lambda kv: -len(kv[0])):
        if text.endswith(suffix):
            return _number(text[: -len(suffix)], field, text) * factor
    return _number(text, field, text)


def _number(text: str, field: str, original: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise InvalidInput(
            field, original, "a number, optionally with a unit: " + ", ".join(UNITS)
        ) from None
    if not math.isfinite(x):
        raise InvalidInput(field, original, "a finite number")
    return x


def parse_vector(text: str, field: str) -> tuple[float, ...]:
    """``"400,1e4,3,2"`` → a tuple of floats (complex allowed via ``complex_vector``)."""
    return tuple(parse_quantity(p.strip(), field) for p in text.split(",") if p.strip())


def parse_complex_vector(text: str, field: str) -> tuple[complex, ...]:
    try:
        values = tuple(complex(p.strip().replace("i", "j")) for p in text.split(","))
    except ValueError:
        raise InvalidInput(field, text, "comma-separated numbers such as -5,-6+2j,-6-2j") from None
    return values


def read_file(path: Path, plant: Plant) -> Any:
    """A controller file (any format of ``elab template``), read for ``plant``: its
    :class:`elab.controllers.Controller` (a Python one named after the file)."""
    from elab import controllers

    fmt = controllers.format_of(path.name)
    try:
        with path.open("rb") as f:
            data = f.read(controllers.file_format.MAX_BYTES + 1)
    except OSError as exc:
        raise InvalidInput("file", str(path), f"a readable file ({exc.strerror})") from None
    ctrl = controllers.read_controller(data, fmt, plant)
    match ctrl.law:
        case CodeController(source=source):  # named after its file
            return replace(ctrl, law=CodeController(source, path.name))
        case _:
            return ctrl


def parse_law(text: str, plant: Plant, estimate: str) -> ControlLaw:
    """``predefined`` | ``open`` | ``K:k1,k2,...`` | ``pid:Kp,Ki,Kd`` | ``lqr:Q1,..,Qn;R``
    | a controller file (``my.py``, ``my.toml``, ...)."""
    if text.rsplit(".", 1)[-1].lower() in ("toml", "json", "mat", "npz", "py"):
        return read_file(Path(text), plant).law  # type: ignore[no-any-return]
    kind, _, arg = text.partition(":")
    if kind == "predefined":
        return plant.predefined
    if kind == "open":
        return OpenLoop()
    if kind == "K":
        return StateFeedback(parse_vector(arg, "controller.K"), estimate)  # type: ignore[arg-type]
    if kind == "pid":
        gains = parse_vector(arg, "controller.pid")
        if not 1 <= len(gains) <= 3:
            raise InvalidInput("controller.pid", arg, "1 to 3 gains: Kp[,Ki[,Kd]]")
        return PID(*gains)
    if kind == "lqr":
        from elab import design

        q, _, r = arg.partition(";")
        K = design.design_lqr(plant, parse_vector(q, "Q"), parse_quantity(r or "1", "R")).K
        return StateFeedback(tuple(float(k) for k in np.ravel(K)), estimate)  # type: ignore[arg-type]
    raise InvalidInput(
        "controller",
        text,
        "predefined, open, K:k1,..,kn, pid:Kp,Ki,Kd, lqr:q1,..,qn;R or a controller file "
        "(.toml, .json, .mat, .npz, .py)",
    )
