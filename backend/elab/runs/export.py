"""Recordings as downloadable files: CSV, JSON and MATLAB ``.mat``.

A :class:`Table` holds what every format needs: header lines, the sample time,
the index of the first row, the channels with their units, the data and the
run's parameter changes. Sample ``i`` of a table is at time
``t = (k0 + i)·Ts`` (s). Every format carries each float64 exactly: CSV and
JSON write the shortest decimal that reads back to the same double, ``.mat``
stores the doubles themselves.
"""

from __future__ import annotations

import io
import json
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, fields, is_dataclass
from typing import Any

import numpy as np
import scipy.io
from numpy.typing import NDArray

from elab.errors import DimensionError, InvalidInput
from elab.sim.result import Samples
from elab.store import ParamChange

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Table:
    """A recording ready to export: ``data[i, j]`` is channel ``j`` at ``t[i]``."""

    header: dict[str, str]  # e.g. plant, controller, signal, run id, status (in this order)
    Ts: float  # s
    k0: int  # index of the first row
    channels: tuple[tuple[str, str], ...]  # (name, unit) of data's columns (no time column)
    data: Array  # (n, nch)
    param_changes: tuple[ParamChange, ...] = ()

    def __post_init__(self) -> None:
        if self.data.ndim != 2 or self.data.shape[1] != len(self.channels):
            raise DimensionError("data", self.data.shape,
                                 f"shape (n, {len(self.channels)}), one column per channel")
        names = [name for name, _ in self.channels]
        for name in names:
            if names.count(name) > 1:
                raise InvalidInput("channels", name, "unique channel names")
        self.data.setflags(write=False)

    @property
    def t(self) -> Array:
        """Sample times (s)."""
        n = self.data.shape[0]
        return np.asarray((self.k0 + np.arange(n)) * self.Ts, dtype=np.float64)


def table_from_samples(samples: Samples, header: dict[str, str]) -> Table:
    """The channels of ``samples`` (``r, u, y…, x…``) as a table."""
    chans = samples.channels()[1:]  # without t, which a table computes
    return Table(header, samples.Ts, samples.k0, tuple((c.name, c.unit) for c, _ in chans),
                 np.column_stack([v for _, v in chans]))


def select(table: Table, channels: list[str] | None = None, t_from: float | None = None,
           t_to: float | None = None) -> Table:
    """The given channels (all if ``None``, in the order given) at times in ``[t_from, t_to]``.

    A sample is kept when its time ``(k0 + i)·Ts`` lies in the closed interval;
    parameter changes made after the last kept sample are dropped.
    """
    cols = _columns(table, channels)
    i0, i1 = _rows(table, t_from, t_to)
    k_end = table.k0 + i1
    return Table(table.header, table.Ts, table.k0 + i0, tuple(table.channels[j] for j in cols),
                 table.data[i0:i1][:, cols],
                 tuple(c for c in table.param_changes if c.k < k_end))


def to_csv(data: Table | Samples, header: dict[str, str] | None = None) -> str:
    """CSV: ``# key: value`` lines, sample time, parameter changes, units, names, rows.

    ``header`` is for :class:`Samples` only; a table carries its own.
    """
    if isinstance(data, Samples):
        return "".join(iter_csv(table_from_samples(data, header or {})))
    if header is not None:
        raise TypeError("to_csv(table) takes no header: a Table carries its own")
    return "".join(iter_csv(data))


def iter_csv(table: Table, rows_per_part: int = 8192) -> Iterator[str]:
    """The CSV of :func:`to_csv` in parts (for a streamed download).

    Numbers are written as Python's ``repr``: the shortest decimal that reads
    back to the same float64.
    """
    lines = [f"# {line}\n" for line in _header_lines(table)]
    lines.append("# units: " + ", ".join(f"{n} [{u}]" for n, u in _with_time(table)) + "\n")
    lines.append(",".join(n for n, _ in _with_time(table)) + "\n")
    yield "".join(lines)
    row = ",".join(["%r"] * (1 + len(table.channels))) + "\n"
    t = table.t
    for i in range(0, t.size, rows_per_part):
        part = np.column_stack([t[i:i + rows_per_part], table.data[i:i + rows_per_part]])
        yield (row * part.shape[0]) % tuple(part.ravel().tolist())


def to_json(table: Table) -> bytes:
    """UTF-8 JSON: header, Ts, k0, channels, t, data by channel name, parameter changes.

    Raises :class:`InvalidInput` if a value is NaN or infinite (JSON has neither).
    """
    t = table.t
    bad = np.argwhere(~np.isfinite(table.data))
    if bad.size:
        i, j = bad[0]
        name = table.channels[j][0]
        raise InvalidInput(f"data.{name}", float(table.data[i, j]),
                           f"finite values (at t = {t[i]:g} s; JSON has no NaN or infinity, "
                           "export CSV or .mat instead)")
    doc = {"header": table.header, "Ts": table.Ts, "k0": table.k0,
           "channels": [{"name": n, "unit": u} for n, u in table.channels],
           "t": t.tolist(),
           "data": {n: table.data[:, j].tolist() for j, (n, _) in enumerate(table.channels)},
           "param_changes": [{"k": c.k, "t": c.k * table.Ts, "params": c.params}
                             for c in table.param_changes]}
    return json.dumps(doc, allow_nan=False, separators=(",", ":")).encode("utf-8")


def to_mat(table: Table) -> bytes:
    """MATLAB ``.mat`` (version 5): ``t`` and one ``n×1`` variable per channel.

    Also ``Ts``, ``k0``, ``channels`` (cell of the variable names, in column
    order), ``units`` (cell of ``"name [unit]"``), ``header`` (char rows
    ``"key: value"``) and, if any, ``param_changes`` (char rows). A channel
    name that is not a MATLAB identifier, or is taken, is sanitised
    (``"1x" → "c_1x"``, ``"a-b" → "a_b"``, ``"t" → "t_2"``).
    """
    names = _matlab_names([n for n, _ in table.channels])
    mdict: dict[str, Any] = {"t": table.t[:, None], "Ts": np.float64(table.Ts),
                             "k0": np.float64(table.k0)}
    for j, var in enumerate(names):
        mdict[var] = np.ascontiguousarray(table.data[:, j:j + 1])
    mdict["channels"] = np.array(names, dtype=object)
    mdict["units"] = np.array([f"{n} [{u}]" for n, u in table.channels], dtype=object)
    mdict["header"] = np.array([f"{k}: {v}" for k, v in table.header.items()] or [""])
    if table.param_changes:
        mdict["param_changes"] = np.array([_change_line(table, c) for c in table.param_changes])
    out = io.BytesIO()
    scipy.io.savemat(out, mdict, format="5", oned_as="column")
    return out.getvalue()


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


# -- helpers -------------------------------------------------------------------
_RESERVED = frozenset({"t", "Ts", "k0", "channels", "units", "header", "param_changes"})
_MATLAB_KEYWORDS = frozenset({
    "break", "case", "catch", "classdef", "continue", "else", "elseif", "end", "for",
    "function", "global", "if", "otherwise", "parfor", "persistent", "return", "spmd",
    "switch", "try", "while"})
_NAMELENGTHMAX = 63


def _columns(table: Table, channels: list[str] | None) -> list[int]:
    names = [n for n, _ in table.channels]
    if channels is None:
        return list(range(len(names)))
    known = f"one of: {', '.join(names)}"
    if not channels:
        raise InvalidInput("channels", channels, f"at least {known}")
    for name in channels:
        if name not in names:
            raise InvalidInput("channels", name, known)
        if channels.count(name) > 1:
            raise InvalidInput("channels", name, "each channel at most once")
    return [names.index(name) for name in channels]


def _rows(table: Table, t_from: float | None, t_to: float | None) -> tuple[int, int]:
    for field, value in (("t_from", t_from), ("t_to", t_to)):
        if value is not None and not math.isfinite(value):
            raise InvalidInput(field, value, "a finite time in s")
    if t_from is not None and t_to is not None and t_from > t_to:
        raise InvalidInput("t_from", t_from, f"a time <= t_to = {t_to:g} s")
    t = table.t
    i0 = 0 if t_from is None else int(np.searchsorted(t, t_from, side="left"))
    i1 = t.size if t_to is None else int(np.searchsorted(t, t_to, side="right"))
    return i0, max(i0, i1)


def _header_lines(table: Table) -> list[str]:
    lines = [f"{k}: {v}" for k, v in table.header.items()]
    lines.append(f"sample time: {table.Ts:g} s")
    lines += [f"parameter changes: {_change_line(table, c)}" for c in table.param_changes]
    return [" ".join(line.splitlines()) for line in lines]  # one line each, whatever the text


def _change_line(table: Table, change: ParamChange) -> str:
    return f"k={change.k}, t={change.k * table.Ts:.12g} s: {json.dumps(change.params)}"


def _with_time(table: Table) -> list[tuple[str, str]]:
    return [("t", "s"), *table.channels]


def _matlab_names(names: list[str]) -> list[str]:
    taken = set(_RESERVED)
    out = []
    for name in names:
        var = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if not re.match(r"[A-Za-z]", var) or var in _MATLAB_KEYWORDS:
            var = "c_" + var
        var = base = var[:_NAMELENGTHMAX]
        i = 2
        while var in taken:
            suffix = f"_{i}"
            var = base[:_NAMELENGTHMAX - len(suffix)] + suffix
            i += 1
        taken.add(var)
        out.append(var)
    return out
