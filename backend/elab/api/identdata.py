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
from typing import TypeVar

from starlette.requests import Request

from elab.api import convert
from elab.api import schemas as s
from elab.api.auth import identity
from elab.api.state import lab
from elab.errors import InvalidInput
from elab.ident import IdData
from elab.ident.data import MAX_SAMPLES, fill_gaps
from elab.ident.files import Table
from elab.plants import get_plant

T = TypeVar("T")
#: a file's text and format → its table (the caller decides where it is parsed)
#: a file's table from its bytes, format, most samples and why that many
Parse = Callable[[bytes, str, int, str], Awaitable[Table]]


async def records(
    request: Request, req: s.IdentRequest, parse: Parse
) -> tuple[IdData, IdData | None, convert.Requested | None]:
    """The data, the validation record (``None``: the data are split) and, for a run,
    what its request says of how it ran (a sine's frequency, closed loop)."""
    data, ran = await _dataset(request, req.data, "data", parse)
    if req.validation is None:
        return data, None, ran
    room = (
        MAX_SAMPLES - data.N,
        f" (with the data's {data.N:,}, at most {MAX_SAMPLES:,} in all)",
    )
    validation, _ = await _dataset(request, req.validation, "validation", parse, room)
    return data, _like(data, validation), ran


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
) -> tuple[IdData, convert.Requested | None]:
    """The data set of the request's field ``prefix`` and, for a run, what its request
    says of how it ran; a file of more samples than ``room`` allows (with why) is refused
    before it is parsed."""
    if isinstance(src, s.FileData):
        try:
            table = await parse(src.text.encode(), src.format, *room)
        except InvalidInput as exc:
            raise _renamed(prefix, exc) from None
        return _prefixed(prefix, lambda: table.dataset(src.input, src.output, src.Ts)), None
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
    return data, convert.requested(record)


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
