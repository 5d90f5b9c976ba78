"""The records an identification request names, read and checked before anything is
computed: ``data`` (a run's recording or an uploaded table) and, if given, a separate
``validation`` record in the same form, with the data's sample time and channels. An
error names the request's field: ``data.input``, ``validation.Ts``, ``validation row 18``
(a row of the validation file), ``validation`` (the two records over
:data:`~elab.ident.data.MAX_SAMPLES` samples together).
"""

from __future__ import annotations

import math
import re
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray
from pydantic import ValidationError
from starlette.requests import Request

from elab.api import convert
from elab.api import schemas as s
from elab.api.auth import identity
from elab.api.state import lab
from elab.errors import InvalidInput
from elab.ident import IdData
from elab.ident.closedloop import References
from elab.ident.data import MAX_SAMPLES, fill_gaps
from elab.ident.files import Table
from elab.plants import get_plant
from elab.sim.signals import Signal
from elab.store.base import RunRecord

Array = NDArray[np.float64]

T = TypeVar("T")
#: a file's text and format → its table (the caller decides where it is parsed)
#: a file's table from its bytes, format, most samples and why that many
Parse = Callable[[bytes, str, int, str], Awaitable[Table]]


@dataclass(frozen=True)
class Records:
    """What an identification request's records are: the ``data``, the ``validation``
    record (``None``: the data are split), for a run what its request says of how it ran
    (a sine's frequency, closed loop), and the signals that drove the loop (asked for by
    ``two_stage`` only)."""

    data: IdData
    validation: IdData | None
    ran: convert.Requested | None
    references: References | None


async def records(request: Request, req: s.IdentRequest, parse: Parse) -> Records:
    staged = req.two_stage is not None
    data, ran, refs = await _dataset(request, req.data, "data", parse, staged=staged)
    if req.validation is None:
        return Records(data, None, ran, refs)
    room = (
        MAX_SAMPLES - data.N,
        f" (with the data's {data.N:,}, at most {MAX_SAMPLES:,} in all)",
    )
    validation, _, _ = await _dataset(request, req.validation, "validation", parse, room)
    return Records(data, _like(data, validation), ran, refs)


def _like(data: IdData, validation: IdData) -> IdData:
    """The validation record, checked to be like the data: the same sample time and
    channels, and both within :data:`MAX_SAMPLES` together."""
    if not math.isclose(validation.Ts, data.Ts, rel_tol=1e-9):
        raise InvalidInput("validation.Ts", validation.Ts, f"the data's sample time {data.Ts:g} s")
    for fieldname, given, wanted in (
        ("input", validation.input_names, data.input_names),
        ("output", validation.output_names, data.output_names),
    ):
        if given != wanted:
            raise InvalidInput(
                f"validation.{fieldname}", list(given), f"the data's: {', '.join(wanted)}"
            )
    if data.N + validation.N > MAX_SAMPLES:
        raise InvalidInput(
            "validation",
            f"{validation.N:,} samples",
            f"at most {MAX_SAMPLES - data.N:,} (with the data's {data.N:,}, at most "
            f"{MAX_SAMPLES:,} in all)",
        )
    return validation


async def _dataset(
    request: Request,
    src: s.RunData | s.FileData,
    prefix: str,
    parse: Parse,
    room: tuple[int, str] = (MAX_SAMPLES, ""),
    *,
    staged: bool = False,
) -> tuple[IdData, convert.Requested | None, References | None]:
    """The data set of the request's field ``prefix``, for a run what its request says
    of how it ran, and, when ``staged`` (the two-stage method), the signals that drove
    the loop; a file of more samples than ``room`` allows (with why) is refused before
    it is parsed."""
    if isinstance(src, s.FileData):
        try:
            table = await parse(src.text.encode(), src.format, *room)
        except InvalidInput as exc:
            raise _renamed(prefix, exc) from None
        data = _prefixed(prefix, lambda: table.dataset(src.input, src.output, src.Ts))
        if not staged:
            return data, None, None
        if src.reference is None:
            raise InvalidInput(
                f"{prefix}.reference", None, "the columns of the signals that drove the loop"
            )
        names = src.reference

        def columns() -> References:
            try:  # read as inputs are: short gaps filled
                values = table.dataset(names, src.output, src.Ts).u
            except InvalidInput as exc:
                field = "reference" if exc.field == "input" else exc.field
                raise InvalidInput(field, exc.value, exc.allowed) from None
            return References(values, tuple(names))

        return data, None, _prefixed(prefix, columns)
    m = lab(request).manager
    record = await m.get(src.run, identity(request))
    names = [c[0] for c in record.channels]
    units = dict(record.channels)
    outputs = src.output or [
        get_plant(record.plant).outputs[get_plant(record.plant).reference_output].name
    ]
    for fieldname, chosen in (("input", src.input), ("output", outputs)):
        for name in chosen:
            if name not in names:
                raise InvalidInput(
                    f"{prefix}.{fieldname}",
                    name,
                    f"channels of run {record.id}: {', '.join(names)}",
                )
    end = record.n_stored * record.Ts
    for name, t in (("t_from", src.t_from), ("t_to", src.t_to)):
        if t is not None and not 0 <= t <= end:
            raise InvalidInput(
                f"{prefix}.{name}", t, f"a time in [0, {end:g}] s (run {record.id}'s recording)"
            )
    k0 = 0 if src.t_from is None else round(src.t_from / record.Ts)
    k1 = None if src.t_to is None else round(src.t_to / record.Ts) + 1
    if k1 is not None and k1 <= k0:
        raise InvalidInput(f"{prefix}.t_to", src.t_to, f"a time after t_from ({src.t_from} s)")
    rows = await m.read(record.id, k0, k1)
    if rows.shape[0] < 2:
        raise InvalidInput(
            f"{prefix}.run",
            record.id,
            f"a run with recorded samples in the range (it has {record.n_stored})",
        )
    refs = _run_references(record, src, prefix, names, rows, k0) if staged else None
    col = {n: i for i, n in enumerate(names)}
    picked = rows[:, [col[n] for n in [*outputs, *src.input]]]
    picked, filled = _prefixed(prefix, lambda: fill_gaps(picked, record.Ts, f"run {record.id}"))
    ny = len(outputs)
    data = _prefixed(
        prefix,
        lambda: IdData(
            picked[:, :ny],
            picked[:, ny:],
            record.Ts,
            output_names=tuple(outputs),
            input_names=tuple(src.input),
            output_units=tuple(units[n] for n in outputs),
            input_units=tuple(units[n] for n in src.input),
            k0=k0,
            filled=filled,
        ),
    )
    return data, convert.requested(record), refs


def _run_references(
    record: RunRecord, src: s.RunData, prefix: str, names: list[str], rows: Array, k0: int
) -> References:
    """The signals that drove a run's loop on the samples read (``rows`` from ``k0``):
    recorded channels by name, and ``excitation``, the run's input excitation as its
    request asked for it (it is not recorded; a reference excitation is in ``r``)."""
    excitation = _input_excitation(record)
    chosen = src.reference or ["r", *(["excitation"] if excitation is not None else [])]
    columns: list[Array] = []
    signals: list[tuple[int, Signal]] = []
    for name in chosen:
        if name == "excitation":
            if excitation is None:
                raise InvalidInput(
                    f"{prefix}.reference",
                    name,
                    f"channels of run {record.id}: {', '.join(names)} (it had no excitation "
                    "at the input)",
                )
            # sampled by the identification worker (a PRBS's generator is scipy's)
            signals.append((len(columns), excitation))
            columns.append(np.zeros(rows.shape[0]))
        elif name in names:
            columns.append(rows[:, names.index(name)])
        else:
            raise InvalidInput(
                f"{prefix}.reference",
                name,
                f"channels of run {record.id}: {', '.join(names)}, or excitation",
            )
    values = np.column_stack(columns)
    if not np.all(np.isfinite(values)):  # a gap in the recording: filled as the data are
        values, _ = fill_gaps(values, record.Ts, f"run {record.id}")
    return References(values, tuple(chosen), tuple(signals), k0, record.Ts)


def _input_excitation(record: RunRecord) -> Signal | None:
    """The excitation a run added at the plant input, as its stored request asked."""
    spec = record.spec
    if spec.get("excitation_at", "input") != "input" or not spec.get("excitation"):
        return None
    try:
        asked = s.RunCreate.model_validate(
            {k: v for k, v in spec.items() if k in s.RunCreate.model_fields}
        )
    except ValidationError:
        return None  # a request an earlier version stored that this one cannot read
    return None if asked.excitation is None else convert.signal(asked.excitation)


def _prefixed(prefix: str, make: Callable[[], T]) -> T:
    try:
        return make()
    except InvalidInput as exc:
        raise _renamed(prefix, exc) from None


def _renamed(prefix: str, exc: InvalidInput) -> InvalidInput:
    """``exc`` naming the request's field ``prefix`` (``data`` or ``validation``): ``Ts`` →
    ``validation.Ts``; a file's own ``data row 18`` → ``validation row 18``."""
    field, n = re.subn(r"^data(?=[ .]|$)", prefix, exc.field)
    return InvalidInput(field if n else f"{prefix}.{exc.field}", exc.value, exc.allowed)
