"""Recorded samples as a self-describing CSV (the seed's downloadable text file)."""

from __future__ import annotations

import io
from dataclasses import fields, is_dataclass
from typing import Any

import numpy as np

from elab.sim.result import Samples


def describe(obj: Any) -> str:
    """``Kind(a=1, b=2)`` for a law or signal dataclass, numbers in short form."""
    if not is_dataclass(obj):
        return str(obj)
    parts = []
    for f in fields(obj):
        v = getattr(obj, f.name)
        if v is None:
            continue
        if isinstance(v, tuple) and len(v) > 8:
            v = f"<{len(v)} values>"
        elif isinstance(v, tuple):
            v = "[" + " ".join(f"{x:g}" if isinstance(x, float) else str(x) for x in v) + "]"
        elif isinstance(v, float):
            v = f"{v:g}"
        parts.append(f"{f.name}={v}")
    return f"{type(obj).__name__}({', '.join(parts)})"


def to_csv(samples: Samples, header: dict[str, str]) -> str:
    """CSV with ``# key: value`` header lines, a units line, then one row per sample."""
    chans = samples.channels()
    out = io.StringIO()
    for key, value in header.items():
        out.write(f"# {key}: {value}\n")
    out.write(f"# sample time: {samples.Ts:g} s\n")
    out.write("# units: " + ", ".join(f"{c.name} [{c.unit}]" for c, _ in chans) + "\n")
    out.write(",".join(c.name for c, _ in chans) + "\n")
    data = np.column_stack([v for _, v in chans])
    np.savetxt(out, data, delimiter=",", fmt="%.10g")
    return out.getvalue()
