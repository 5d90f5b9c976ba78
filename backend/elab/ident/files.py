"""Data sets from files: E-Lab's own CSV and JSON downloads, or plain numeric tables
(comma- or whitespace-separated, as MATLAB's and DaISy's ``.dat`` files).

A table is named columns with units and a sample time. CSV: optional ``#`` header lines
(E-Lab writes ``# sample time: 0.001 s`` and ``# units: t [s], u [V], …``), then a row of
column names (or none: the columns are ``c1, c2, …``), then one row of numbers per
sample. JSON: E-Lab's download (``Ts``, ``channels``, ``data``) or ``{"Ts": …, "u": […],
"y": […]}`` with any column names. The sample time comes from the file, else from a
``t`` column with even steps, else it must be given.
"""

from __future__ import annotations

import csv
import json
import re
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import MAX_SAMPLES, TS_RANGE, IdData, fill_gaps

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Table:
    """Named columns of equal length, with units and (if known) the sample time."""

    names: tuple[str, ...]
    units: tuple[str, ...]
    data: Array  # (N, columns)
    Ts: float | None

    def column(self, name: str, field: str) -> Array:
        if name not in self.names:
            raise InvalidInput(field, name, f"one of the columns: {', '.join(self.names)}")
        return self.data[:, self.names.index(name)]

    def dataset(self, inputs: list[str], outputs: list[str], Ts: float | None = None) -> IdData:
        """The identification data: ``inputs`` and ``outputs`` by column name."""
        if not inputs:
            raise InvalidInput("input", inputs, "at least one input column")
        if not outputs:
            raise InvalidInput("output", outputs, "at least one output column")
        ts = Ts if Ts is not None else self.Ts
        if ts is None:
            raise InvalidInput(
                "Ts",
                None,
                "a sample time: the file has none (no '# sample "
                "time' line and no evenly spaced 't' column)",
            )
        u = np.column_stack([self.column(n, "input") for n in inputs])
        y = np.column_stack([self.column(n, "output") for n in outputs])
        # a sample nobody measured (NaN in CSV, null in E-Lab's JSON): short gaps filled
        both, filled = fill_gaps(np.column_stack([y, u]), ts, "the file")
        y, u = both[:, : y.shape[1]], both[:, y.shape[1] :]
        unit = dict(zip(self.names, self.units, strict=True))
        return IdData(
            y,
            u,
            ts,
            filled=filled,
            output_names=tuple(outputs),
            input_names=tuple(inputs),
            output_units=tuple(unit[n] for n in outputs),
            input_units=tuple(unit[n] for n in inputs),
        )


def read_csv(text: str, max_rows: int = MAX_SAMPLES, why: str = "") -> Table:
    """A table from CSV text of at most ``max_rows`` samples (``why``: what the limit
    is, said when it is passed; it is checked before any row is parsed)."""
    lines = text.splitlines()
    header = [ln[1:].strip() for ln in lines if ln.startswith("#")]
    body = [ln for ln in lines if ln.strip() and not ln.startswith("#")]
    if not body:
        raise InvalidInput("data", "no rows", "CSV with one row of numbers per sample")
    sep = _separator(body[:20])
    n = len(body) - (0 if _numeric(_cells(body[0], 1, sep)) else 1)
    if n > max_rows:  # 2 million rows took 8 s to parse, only to be refused
        raise InvalidInput("data", f"{n:,} samples", f"at most {max_rows:,} samples{why}")
    rows = [_cells(ln, i + 1, sep) for i, ln in enumerate(body)]
    names: list[str]
    if _numeric(rows[0]):
        names = [f"c{i + 1}" for i in range(len(rows[0]))]
    else:
        names = [n.strip() for n in rows[0]]
        rows = rows[1:]
    if len(rows) < 2:
        raise InvalidInput("data", f"{len(rows)} rows", "at least 2 samples")
    if len(rows) > MAX_SAMPLES:
        raise InvalidInput("data", f"{len(rows):,} rows", f"at most {MAX_SAMPLES:,} samples")
    names, rows, column_Ts = _metadata_Ts(names, rows)
    data = np.empty((len(rows), len(names)))
    for i, row in enumerate(rows):
        if len(row) != len(names):
            comma = (
                " (if the file writes decimal commas, as 1,5, its columns must be separated "
                "by semicolons or tabs: a comma cannot be both)"
                if sep == ","
                else ""
            )
            raise InvalidInput(
                f"data row {i + 1}",
                f"{len(row)} values",
                f"{len(names)} values, one per column ({', '.join(names)}){comma}",
            )
        try:
            data[i] = [float(v) for v in row]
        except ValueError:
            raise InvalidInput(f"data row {i + 1}", ",".join(row)[:60], "numbers") from None
        if not np.isfinite(data[i]).all():
            raise InvalidInput(f"data row {i + 1}", ",".join(row)[:60], "finite numbers")
    units = _units(header, names)
    Ts = _header_Ts(header)
    if column_Ts is not None:
        if Ts is not None and not np.isclose(Ts, column_Ts, rtol=1e-9):
            raise InvalidInput(
                "Ts", column_Ts, f"the header's sample time {Ts:g} s (the two differ)"
            )
        Ts = column_Ts
    return _table(names, units, data, Ts)


TS_COLUMNS = ("ts", "dt", "sample_time", "sampletime")


def _metadata_Ts(
    names: list[str], rows: list[list[str]]
) -> tuple[list[str], list[list[str]], float | None]:
    """A sample-time column (``Ts``, ``dt``, …) as benchmark files have it: filled in the
    first row (or some rows) and empty in the others. Taken out of the data, its value
    becomes the sample time; values that differ are refused."""
    found = [i for i, n in enumerate(names) if n.strip().lower() in TS_COLUMNS]
    if not found:
        return names, rows, None
    c = found[0]
    given: list[float] = []
    kept = []
    for i, row in enumerate(rows):
        row = row + [""] * (len(names) - len(row))  # trailing empty cells were dropped
        cell = row[c].strip() if c < len(row) else ""
        if cell:
            try:
                given.append(float(cell))
            except ValueError:
                raise InvalidInput(
                    f"data row {i + 1}", cell, f"a sample time in {names[c]}"
                ) from None
        kept.append(row[:c] + row[c + 1 :])
    if not given:
        raise InvalidInput(names[c], "an empty column", "the sample time in at least one row")
    if not np.allclose(given, given[0], rtol=1e-9, atol=0):
        first = ", ".join(f"{g:g}" for g in sorted(set(given))[:3])
        raise InvalidInput(
            names[c],
            f"{len(set(given))} different values ({first} …)",
            "one sample time (a uniformly sampled record)",
        )
    return names[:c] + names[c + 1 :], kept, given[0]


def read_json(text: str | bytes) -> Table:
    doc = _parse_json(text)
    if not isinstance(doc, dict):
        raise InvalidInput("data", type(doc).__name__, "a JSON object")
    Ts = doc.get("Ts")
    if "data" in doc and isinstance(doc["data"], dict):  # E-Lab's own download
        cols: dict[str, Any] = doc["data"]
        channels = doc.get("channels", [])
        if not isinstance(channels, list):
            raise InvalidInput("data.channels", channels, "a list of {name, unit} objects")
        units = {
            str(c.get("name")): str(c.get("unit", "")) for c in channels if isinstance(c, dict)
        }
        if "t" in doc:
            cols = {"t": doc["t"], **cols}
            units["t"] = "s"
    else:
        cols = {k: v for k, v in doc.items() if k not in ("Ts", "units")}
        units = doc.get("units") or {}
        if not isinstance(units, dict):
            raise InvalidInput("data.units", units, "an object of column name → unit")
    names = [str(k) for k in cols]
    arrays = []
    for name in names:
        try:
            a = np.asarray(cols[name], dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidInput(f"data.{name}", str(cols[name])[:60], "a list of numbers") from None
        if a.ndim != 1:
            raise InvalidInput(f"data.{name}", f"shape {a.shape}", "a flat list of numbers")
        if not np.isfinite(a).all():
            raise InvalidInput(f"data.{name}", str(cols[name])[:60], "finite numbers")
        arrays.append(a)
    if not arrays:
        raise InvalidInput("data", "no columns", "at least one input and one output column")
    lengths = {a.shape[0] for a in arrays}
    if len(lengths) != 1:
        raise InvalidInput("data", f"columns of lengths {sorted(lengths)}", "equal lengths")
    if Ts is not None and (not isinstance(Ts, int | float) or isinstance(Ts, bool)):
        raise InvalidInput("Ts", Ts, "a number of seconds")
    return _table(
        names,
        [str(units.get(n, "")) for n in names],
        np.column_stack(arrays),
        None if Ts is None else float(Ts),
    )


def _table(names: list[str], units: list[str], data: Array, Ts: float | None) -> Table:
    if len(set(names)) != len(names):
        raise InvalidInput("columns", names, "distinct column names")
    if Ts is None and "t" in names:
        t = data[:, names.index("t")]
        steps = np.diff(t)
        if steps.size and steps[0] > 0 and np.allclose(steps, steps[0], rtol=1e-6, atol=0):
            Ts = float(steps[0])
    if Ts is not None and not TS_RANGE[0] <= Ts <= TS_RANGE[1]:
        raise InvalidInput("Ts", Ts, f"a sample time in [{TS_RANGE[0]:g}, {TS_RANGE[1]:g}] s")
    return Table(tuple(names), tuple(units), data, Ts)


def _parse_json(text: str | bytes) -> Any:
    """JSON with every number a float (an integer of 5,000 digits is ``inf``, refused later
    as not finite, instead of Python's ValueError past 4,300 digits); nesting too deep for
    the parser is refused, not a crash."""
    try:
        return json.loads(text, parse_int=float, parse_constant=_no_constant)
    except json.JSONDecodeError as exc:
        raise InvalidInput("data", f"invalid JSON ({exc.msg} at {exc.pos})", "JSON") from None
    except RecursionError:
        raise InvalidInput(
            "data", "JSON nested too deeply", "a JSON object of columns (lists of numbers)"
        ) from None


def _no_constant(name: str) -> float:
    raise InvalidInput("data", name, "finite numbers (JSON has no NaN or Infinity)")


def _separator(lines: list[str]) -> str | None:
    """How the columns are separated: semicolons where every line has them, tabs where
    every line has them and the numbers decimal commas (the CSV of spreadsheets in
    decimal-comma locales), else commas where a line has one, else whitespace (None:
    MATLAB's and DaISy's ``.dat`` files)."""
    commas = any("," in ln for ln in lines)
    if all(";" in ln for ln in lines):
        return ";"
    if commas and all("\t" in ln for ln in lines):  # tabs and decimal commas
        return "\t"
    return "," if commas else None


DECIMAL_COMMA = re.compile(r"[+-]?\d*,\d+([eE][+-]?\d+)?")


def _cells(line: str, row: int, sep: str | None = None) -> list[str]:
    """The values of line ``row`` (of those not comments), separated by ``sep``: commas
    (quotes allowed), semicolons or tabs (where a number's decimal comma is read as a
    point: 1,5 is 1.5), or whitespace; trailing empty cells dropped."""
    try:
        if sep == ",":
            cells = next(csv.reader([line]))
        elif sep in (";", "\t"):
            cells = next(csv.reader([line], delimiter=sep))
            cells = [
                c.replace(",", ".") if DECIMAL_COMMA.fullmatch(c.strip()) else c for c in cells
            ]
        else:
            cells = next(csv.reader([line])) if "," in line else line.split()
    except csv.Error as exc:  # e.g. a field longer than the csv module's 128 KiB limit
        raise InvalidInput(f"data line {row}", line[:60], f"CSV cells ({exc})") from None
    cells = [c.strip() for c in cells]
    while cells and not cells[-1]:
        cells.pop()
    return cells


def _numeric(row: list[str]) -> bool:
    try:
        [float(v) for v in row]
    except ValueError:
        return False
    return True


def _header_Ts(header: list[str]) -> float | None:
    for line in header:
        m = re.match(r"sample time:\s*(\S+)\s*s\b", line)
        if m:
            try:
                return float(m.group(1))
            except ValueError:
                raise InvalidInput(
                    "data",
                    f"# {line[:60]}",
                    "a header line '# sample time: <seconds> s', e.g. '# sample time: 0.001 s'",
                ) from None
    return None


def _units(header: list[str], names: list[str]) -> list[str]:
    for line in header:
        if line.startswith("units:"):
            found = dict(re.findall(r"([^,\s]+) \[([^\]]*)\]", line[len("units:") :]))
            return [found.get(n, "") for n in names]
    return ["" for _ in names]


def read_table(raw: bytes, fmt: str, max_rows: int = MAX_SAMPLES, why: str = "") -> Table:
    """A table from an uploaded file's bytes (``fmt``: ``csv`` or ``json``); a CSV file of
    more than ``max_rows`` samples is refused before it is parsed (see :func:`read_csv`)."""
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InvalidInput(
            "data", "bytes that are not UTF-8 text", "a CSV or JSON text file"
        ) from None
    if fmt == "csv":
        return read_csv(text, max_rows, why)
    if fmt == "json":
        return read_json(text)
    raise InvalidInput("format", fmt, "csv or json")
