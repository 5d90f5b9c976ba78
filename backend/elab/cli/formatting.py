"""How the commands print numbers: complex values as text or as ``[re, im]`` pairs, JSON
without NaN or infinity."""

from __future__ import annotations

import json
import math
from typing import Any


def complex_text(z: complex) -> str:
    z = complex(z)
    if abs(z.imag) < 1e-12:
        return f"{z.real:.6g}"
    return f"{z.real:.6g}{z.imag:+.6g}j"


def complex_list(zs: Any) -> list[list[float]]:
    return [[float(complex(z).real), float(complex(z).imag)] for z in zs]


def finite_or_none(x: float) -> float | None:
    """JSON has no NaN or infinity: undefined figures become null."""
    return float(x) if math.isfinite(x) else None


def json_text(obj: Any) -> str:
    return json.dumps(obj, indent=2)
