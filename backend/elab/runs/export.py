"""Recordings as downloadable files: CSV, JSON and MATLAB ``.mat``.

A :class:`Recording` holds what every format needs: header lines, the sample
time, the index of the first row, the channels with their units, the run's
parameter changes, and a function that reads its rows in parts; a
:class:`Table` is one held in memory. Row ``i`` is at time ``t = (k0 + i)·Ts``
(s). Each format is written in parts (``iter_csv``, ``iter_json``,
``iter_mat``) of at most a few MiB, so a download of any length holds one part in
memory, not the recording. Every format carries each float64 exactly: CSV and JSON
write the shortest decimal that reads back to the same double (formatted a part at a
time by orjson, a compiled JSON writer: ten times Python's ``repr``), ``.mat`` stores the
doubles themselves, each variable's header written here so that a column is streamed
part by part.
"""

from __future__ import annotations

import io
import json
import math
import os
import re
import struct
import tempfile
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, fields, is_dataclass
from typing import Any

import numpy as np
import orjson
from numpy.typing import NDArray

from elab.errors import DimensionError, InvalidInput
from elab.plants.base import Plant
from elab.sim.result import Samples
from elab.store import ParamChange

Array = NDArray[np.float64]


Reader = Callable[[int, int], Array]
#: rows read and sent at a time for JSON and .mat, which write one column of them (0.5 MiB
#: of doubles, about 1.2 MiB of text): what a download holds in memory
PART = 65_536
#: rows at a time for CSV, which writes every column of them (8,192 rows of 10 columns:
#: about 1.5 MiB of text)
CSV_PART = 8_192
_NUMPY = orjson.OPT_SERIALIZE_NUMPY  # orjson writes a numpy array's numbers itself


@dataclass(frozen=True)
class Recording:
    """A recording to export, read in parts: ``read(i0, i1)`` gives rows ``i0 .. i1−1``
    (one column per channel). Row ``i`` is sample ``k0 + i``, at ``t = (k0 + i)·Ts``."""

    header: dict[str, str]  # e.g. plant, controller, signal, run id, status (in this order)
    Ts: float  # s
    k0: int
    n: int
    channels: tuple[tuple[str, str], ...]  # (name, unit) of the columns (no time column)
    read: Reader
    param_changes: tuple[ParamChange, ...] = ()

    def __post_init__(self) -> None:
        names = [name for name, _ in self.channels]
        for name in names:
            if names.count(name) > 1:
                raise InvalidInput("channels", name, "unique channel names")

    def t(self, i0: int = 0, i1: int | None = None) -> Array:
        """Times of rows ``i0 .. i1−1`` (s)."""
        i1 = self.n if i1 is None else i1
        return np.asarray((self.k0 + np.arange(i0, i1)) * self.Ts, dtype=np.float64)

    def parts(self, rows: int = PART) -> Iterator[tuple[int, Array]]:
        """``(i0, rows i0 …)`` in order, ``rows`` at a time."""
        for i0 in range(0, self.n, rows):
            yield i0, self.read(i0, min(self.n, i0 + rows))


@dataclass(frozen=True)
class Table:
    """A recording held in memory: ``data[i, j]`` is channel ``j`` at ``t[i]``."""

    header: dict[str, str]
    Ts: float  # s
    k0: int  # index of the first row
    channels: tuple[tuple[str, str], ...]
    data: Array  # (n, nch)
    param_changes: tuple[ParamChange, ...] = ()

    def __post_init__(self) -> None:
        if self.data.ndim != 2 or self.data.shape[1] != len(self.channels):
            raise DimensionError(
                "data", self.data.shape, f"shape (n, {len(self.channels)}), one column per channel"
            )
        self.data.setflags(write=False)
        self.recording  # noqa: B018  (checks the channel names)

    @property
    def t(self) -> Array:
        """Sample times (s)."""
        return self.recording.t()

    @property
    def recording(self) -> Recording:
        data = self.data
        return Recording(
            self.header,
            self.Ts,
            self.k0,
            data.shape[0],
            self.channels,
            lambda i0, i1: data[i0:i1],
            self.param_changes,
        )


def table_from_samples(samples: Samples, header: dict[str, str]) -> Table:
    """The channels of ``samples`` (``r, u, y…, x…``) as a table."""
    chans = samples.channels()[1:]  # without t, which a table computes
    return Table(
        header,
        samples.Ts,
        samples.k0,
        tuple((c.name, c.unit) for c, _ in chans),
        np.column_stack([v for _, v in chans]),
    )


def select(
    rec: Recording | Table,
    channels: list[str] | None = None,
    t_from: float | None = None,
    t_to: float | None = None,
) -> Recording:
    """The given channels (all if ``None``, in the order given) at times in ``[t_from, t_to]``.

    A sample is kept when its time ``(k0 + i)·Ts`` lies in the closed interval;
    parameter changes made after the last kept sample are dropped.
    """
    rec = rec.recording if isinstance(rec, Table) else rec
    cols = _columns(rec, channels)
    i0, i1 = _rows(rec, t_from, t_to)
    read = rec.read

    def part(a: int, b: int) -> Array:
        return read(i0 + a, i0 + b)[:, cols]

    return Recording(
        rec.header,
        rec.Ts,
        rec.k0 + i0,
        i1 - i0,
        tuple(rec.channels[j] for j in cols),
        part,
        tuple(c for c in rec.param_changes if c.k < rec.k0 + i1),
    )


def to_csv(data: Table | Recording | Samples, header: dict[str, str] | None = None) -> str:
    """CSV: ``# key: value`` lines, sample time, parameter changes, units, names, rows.

    ``header`` is for :class:`Samples` only; a table carries its own.
    """
    if isinstance(data, Samples):
        return b"".join(iter_csv(table_from_samples(data, header or {}).recording)).decode()
    if header is not None:
        raise TypeError("to_csv(table) takes no header: a Table carries its own")
    return b"".join(iter_csv(_recording(data))).decode()


def iter_csv(rec: Recording, rows: int = CSV_PART) -> Iterator[bytes]:
    """The UTF-8 CSV of :func:`to_csv` in parts (a streamed download holds one part at a
    time).

    Numbers are the shortest decimal that reads back to the same float64 (``0.001``,
    ``1e-05``: any CSV reader's float parser reads them back exactly); a sample nobody
    measured is ``nan``, an infinite one ``inf`` or ``-inf``.
    """
    lines = [f"# {line}\n" for line in _header_lines(rec)]
    lines.append("# units: " + ", ".join(f"{n} [{u}]" for n, u in _with_time(rec)) + "\n")
    lines.append(",".join(n for n, _ in _with_time(rec)) + "\n")
    yield "".join(lines).encode()
    for i0, data in rec.parts(rows):
        if data.shape[0]:
            t = _clean_times(rec.t(i0, i0 + data.shape[0]), rec.Ts)
            yield _csv_rows(np.column_stack([t, data]))


def _csv_rows(part: Array) -> bytes:
    """The rows of ``part`` (at least one) as CSV lines: orjson writes the part as a JSON
    list of rows, ``[[a,b],[c,d]]``, whose brackets become line ends."""
    text = _json_array(part)[2:-2].replace(b"],[", b"\n") + b"\n"
    finite = np.isfinite(part)
    if finite.all():
        return text
    if not np.isinf(part[~finite]).any():
        return text.replace(b"null", b"nan")  # (JSON's null: the only letters in the part)
    # infinities (a diverging law's last samples, with saturation off): Python's repr
    row = ",".join(["%r"] * part.shape[1]) + "\n"
    text = (row * part.shape[0]) % tuple(part.ravel().tolist())
    return str(text).encode()


def _json_array(values: Array) -> bytes:
    """``values`` as a JSON array (nested for 2-D): each number the shortest decimal that
    reads back to the same double, NaN and ±inf as ``null``."""
    return orjson.dumps(np.ascontiguousarray(values, dtype=np.float64), option=_NUMPY)


def _clean_times(t: np.ndarray, Ts: float) -> np.ndarray:
    """k·Ts without the float noise of the product (6.959, not 6.9590000000000005): rounded
    to six decimals below the sample time's, far inside one sample."""
    if not (Ts > 0 and np.isfinite(Ts)):
        return t
    return np.round(t, max(0, 6 - int(np.floor(np.log10(Ts)))))


def to_json(data: Table | Recording) -> bytes:
    """UTF-8 JSON: header, Ts, k0, channels, t, data by channel name, parameter changes.

    A NaN (a sample nobody measured: one a rig dropped) is ``null``; an infinite value
    raises :class:`InvalidInput` (JSON has none).
    """
    return b"".join(iter_json(_recording(data)))


def iter_json(rec: Recording, rows: int = PART) -> Iterator[bytes]:
    """The JSON of :func:`to_json` in parts: the columns one after another, each read in
    parts of ``rows`` (so a download holds one part, not the recording)."""
    head = {
        "header": rec.header,
        "Ts": rec.Ts,
        "k0": rec.k0,
        "channels": [{"name": n, "unit": u} for n, u in rec.channels],
    }
    yield _dumps(head)[:-1].encode() + b',"t":['
    yield from _json_numbers(rec.t(i0, i0 + m) for i0, m in _spans(rec.n, rows))
    yield b'],"data":{'
    for j, (name, _) in enumerate(rec.channels):
        yield (b"," if j else b"") + _dumps(name).encode() + b":["
        yield from _json_numbers(_finite(rec, data[:, j], i0, name) for i0, data in rec.parts(rows))
        yield b"]"
    changes = [{"k": c.k, "t": c.k * rec.Ts, "params": c.params} for c in rec.param_changes]
    yield b'},"param_changes":' + _dumps(changes).encode() + b"}"


def to_mat(data: Table | Recording) -> bytes:
    """MATLAB ``.mat`` (version 5): ``t`` and one ``n×1`` variable per channel."""
    return b"".join(iter_mat(_recording(data)))


def iter_mat(rec: Recording, rows: int = PART) -> Iterator[bytes]:
    """MATLAB ``.mat`` (version 5) in parts: ``t`` and one ``n×1`` variable per channel,
    each written when read (a download holds one column at a time, not the recording).

    Also ``Ts``, ``k0``, ``channels`` (cell of the variable names, in column
    order), ``units`` (cell of ``"name [unit]"``), ``header`` (char rows
    ``"key: value"``) and, if any, ``param_changes`` (char rows). A channel
    name that is not a MATLAB identifier, or is taken, is sanitised
    (``"1x" → "c_1x"``, ``"a-b" → "a_b"``, ``"t" → "t_2"``). A v5 file is a 128-byte
    header and one element per variable. The columns' elements are written here, ``t`` and
    the channels from one pass over the recording (:func:`_mat_columns`); the others are
    files of their variables written by ``scipy.io.savemat``, the header kept from the
    first only. The variables come in the order of a ``savemat`` of ``Ts``, ``k0``, ``t``,
    the channels, then the rest: byte for byte what it writes (a test compares them).
    """
    yield _mat({"Ts": np.float64(rec.Ts), "k0": np.float64(rec.k0)}, header=True)
    names = _matlab_names([n for n, _ in rec.channels])
    yield from _mat_columns(rec, names, rows)
    meta: dict[str, Any] = {
        "channels": np.array(names, dtype=object),
        "units": np.array([f"{n} [{u}]" for n, u in rec.channels], dtype=object),
        "header": np.array([f"{k}: {v}" for k, v in rec.header.items()] or [""]),
    }
    if rec.param_changes:
        meta["param_changes"] = np.array([_change_line(rec, c) for c in rec.param_changes])
    yield _mat(meta)


def sensors_header(plant: Plant, seed: int | None, quantize: bool) -> dict[str, str]:
    """Header lines saying how a run's outputs were measured: ``noise`` (the plant's white
    sensor noise and its seed, ``seed=None``: none) and ``quantisation`` (each output's
    resolution, or none)."""

    def per_output(values: tuple[float, ...]) -> str:
        return ", ".join(
            f"{o.name} {v:.6g} {o.unit}" if v > 0 else f"{o.name} none"
            for o, v in zip(plant.outputs, values, strict=True)
        )

    ideal = "none (ideal sensors)"
    return {
        "noise": ideal
        if seed is None
        else f"white, standard deviation {per_output(plant.sensors.noise_std)} (seed {seed})",
        "quantisation": f"{per_output(plant.sensors.quantum)} (the sensors' resolution)"
        if quantize
        else ideal,
    }


def describe(obj: object) -> str:
    """``Kind(a=1, b=2)`` for a law or signal dataclass, numbers in short form."""
    if not is_dataclass(obj):
        return str(obj)
    parts = []
    for f in fields(obj):
        v = getattr(obj, f.name)
        if v is None or not f.repr:  # (a code controller's source)
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
_MATLAB_KEYWORDS = frozenset(
    {
        "break",
        "case",
        "catch",
        "classdef",
        "continue",
        "else",
        "elseif",
        "end",
        "for",
        "function",
        "global",
        "if",
        "otherwise",
        "parfor",
        "persistent",
        "return",
        "spmd",
        "switch",
        "try",
        "while",
    }
)
_NAMELENGTHMAX = 63


def _recording(data: Table | Recording) -> Recording:
    return data.recording if isinstance(data, Table) else data


def _dumps(obj: Any) -> str:
    return json.dumps(obj, allow_nan=False, separators=(",", ":"))


def _spans(n: int, rows: int) -> Iterator[tuple[int, int]]:
    for i0 in range(0, n, rows):
        yield i0, min(n, i0 + rows) - i0


def _json_numbers(parts: Iterable[Array]) -> Iterator[bytes]:
    """The numbers of the 1-D ``parts``, comma-separated (NaN as ``null``)."""
    first = True
    for values in parts:
        if values.size:
            yield (b"" if first else b",") + _json_array(values)[1:-1]
            first = False


def _finite(rec: Recording, values: Array, i0: int, name: str) -> Array:
    bad = np.flatnonzero(np.isinf(values))
    if bad.size:
        i = i0 + int(bad[0])
        raise InvalidInput(
            f"data.{name}",
            float(values[bad[0]]),
            f"finite values (at t = {float(rec.t(i, i + 1)[0]):g} s; JSON has no "
            "infinity, export CSV or .mat instead)",
        )
    return values


def _mat(mdict: dict[str, Any], header: bool = False) -> bytes:
    import scipy.io  # here: a quarter of a second of imports that CSV and JSON do without

    out = io.BytesIO()
    scipy.io.savemat(out, mdict, format="5", oned_as="column")
    return out.getvalue() if header else out.getvalue()[128:]


# MAT-file v5 data types and the double array class (MathWorks, "MAT-File Format", 1-7)
_MI_INT8, _MI_INT32, _MI_UINT32, _MI_DOUBLE, _MI_MATRIX = 1, 5, 6, 9, 14
_MX_DOUBLE_CLASS = 6


def _mat_columns(rec: Recording, names: list[str], rows: int) -> Iterator[bytes]:
    """The elements of ``t`` and of the channels (``names``), each an ``n×1`` double
    variable, from one pass over the recording: each part's columns are written at their
    places in a temporary file, which is then sent a MiB at a time (a v5 variable is one
    contiguous column: a pass per channel read the store ten times)."""
    heads = [_mat_column_head(var, rec.n) for var in ("t", *names)]
    at = [0]  # where each variable's element starts in the file
    for head in heads:
        at.append(at[-1] + len(head) + 8 * rec.n)
    with tempfile.TemporaryFile(prefix="elab-mat-") as f:
        fd = f.fileno()
        for j, head in enumerate(heads):
            os.pwrite(fd, head, at[j])
        read = 0
        for i0, data in rec.parts(rows):
            m = data.shape[0]
            for j, column in enumerate((rec.t(i0, i0 + m), *data.T)):
                values = np.ascontiguousarray(column, dtype="<f8")
                os.pwrite(fd, values.data, at[j] + len(heads[j]) + 8 * i0)
            read += m
        if read != rec.n:  # heads that promised n values: the file would not load
            raise DimensionError("rows", read, f"{rec.n}, as the variables' heads say")
        f.seek(0)
        while part := f.read(1 << 20):
            yield part


def _mat_column_head(name: str, n: int) -> bytes:
    """What precedes an ``n×1`` double variable's values in a little-endian v5 file: the
    matrix tag, the array flags, the dimensions, the name and the values' tag (elements of
    at most 4 bytes packed into their tag, as the format allows and scipy does)."""
    body = (
        struct.pack("<IIII", _MI_UINT32, 8, _MX_DOUBLE_CLASS, 0)
        + struct.pack("<IIii", _MI_INT32, 8, n, 1)
        + _mat_element(_MI_INT8, name.encode("ascii"))
        + (struct.pack("<II", _MI_DOUBLE, 8 * n) if n else _mat_element(_MI_DOUBLE, b""))
    )
    return struct.pack("<II", _MI_MATRIX, len(body) + 8 * n) + body


def _mat_element(kind: int, data: bytes) -> bytes:
    if len(data) <= 4:
        return struct.pack("<HH", kind, len(data)) + data.ljust(4, b"\0")
    return struct.pack("<II", kind, len(data)) + data.ljust(-(-len(data) // 8) * 8, b"\0")


def _columns(rec: Recording, channels: list[str] | None) -> list[int]:
    names = [n for n, _ in rec.channels]
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


def _rows(rec: Recording, t_from: float | None, t_to: float | None) -> tuple[int, int]:
    """The rows whose times lie in ``[t_from, t_to]``: found on ``t = (k0 + i)·Ts`` by bisection,
    without building the time axis of a long recording."""
    for field, value in (("t_from", t_from), ("t_to", t_to)):
        if value is not None and not math.isfinite(value):
            raise InvalidInput(field, value, "a finite time in s")
    if t_from is not None and t_to is not None and t_from > t_to:
        raise InvalidInput("t_from", t_from, f"a time <= t_to = {t_to:g} s")
    i0 = 0 if t_from is None else _first(rec, lambda t: t >= t_from)
    i1 = rec.n if t_to is None else _first(rec, lambda t: t > t_to)
    return i0, max(i0, i1)


def _first(rec: Recording, after: Callable[[float], bool]) -> int:
    """The first row whose time satisfies ``after`` (monotone in the row), or ``n``."""
    lo, hi = 0, rec.n
    while lo < hi:
        mid = (lo + hi) // 2
        if after(float(rec.t(mid, mid + 1)[0])):
            hi = mid
        else:
            lo = mid + 1
    return lo


def _header_lines(rec: Recording) -> list[str]:
    lines = [f"{k}: {v}" for k, v in rec.header.items()]
    lines.append(f"sample time: {rec.Ts:g} s")
    lines += [f"parameter changes: {_change_line(rec, c)}" for c in rec.param_changes]
    return [" ".join(line.splitlines()) for line in lines]  # one line each, whatever the text


def _change_line(rec: Recording, change: ParamChange) -> str:
    return f"k={change.k}, t={change.k * rec.Ts:.12g} s: {json.dumps(change.params)}"


def _with_time(rec: Recording) -> list[tuple[str, str]]:
    return [("t", "s"), *rec.channels]


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
            var = base[: _NAMELENGTHMAX - len(suffix)] + suffix
            i += 1
        taken.add(var)
        out.append(var)
    return out
