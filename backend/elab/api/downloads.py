"""``/runs/{id}/data``: a run's recording as CSV, JSON or MATLAB .mat, streamed part by
part from the store (:mod:`elab.runs.export` writes the formats)."""

from __future__ import annotations

import json
import zlib
from collections.abc import AsyncIterator, Callable, Iterator
from typing import Any

from starlette.concurrency import iterate_in_threadpool
from starlette.requests import Request
from starlette.responses import Response, StreamingResponse

from elab.access import display_name
from elab.api import convert
from elab.api.auth import identity
from elab.api.http import GZIP_LEVEL, Param, accepts_gzip, endpoint, query, query_float
from elab.api.runs import manager
from elab.errors import InvalidInput
from elab.plants import get_plant
from elab.runs import export
from elab.runs.manager import RunManager
from elab.store.base import RunRecord

FORMATS = {
    "csv": "text/csv; charset=utf-8",
    "json": "application/json",
    "mat": "application/x-matlab-data",
}


@endpoint(
    "GET",
    "/runs/{run_id}/data",
    response="file",
    params=(
        Param(
            "format",
            "query",
            "csv (default), json or mat",
            {"type": "string", "enum": list(FORMATS)},
        ),
        Param("channels", "query", "comma-separated channel names (default: all)"),
        Param("t_from", "query", "first sample time (s)", {"type": "number"}),
        Param("t_to", "query", "last sample time (s)", {"type": "number"}),
    ),
)
async def get_data(request: Request) -> Response:
    """The complete recording as CSV, JSON or MATLAB .mat

    CSV starts with ``# key: value`` lines (plant, controller, signal, sample time, units,
    parameter changes); numbers are the shortest decimals that read back exactly. The file
    is streamed as it is written, part by part (a download of any length holds one part of
    the recording in memory), and stops when the client goes away. A live run downloads
    as stored so far (samples reach the store within a quarter of a second): a download
    never holds a sample that the recording could still lose."""
    fmt = query(request, "format")
    fmt = "csv" if fmt is None else fmt
    if fmt not in FORMATS:
        raise InvalidInput("format", fmt, ", ".join(FORMATS))
    m = manager(request)
    record = await m.get(request.path_params["run_id"], identity(request))
    stored, read = m.durable(record.id)  # at once after: the same moment of a live run
    n = record.n_stored if stored is None else min(stored, record.n_stored)
    changes = await m.param_changes(record.id)
    rec = export.Recording(
        _header(record),
        record.Ts,
        0,
        n,
        record.channels,
        read,
        tuple(c for c in changes if c.k < n),
    )
    names = query(request, "channels")
    rec = export.select(
        rec,
        names.split(",") if names else None,
        query_float(request, "t_from"),
        query_float(request, "t_to"),
    )
    writers: dict[str, Callable[[export.Recording], Iterator[bytes]]] = {
        "csv": export.iter_csv,
        "json": export.iter_json,
        "mat": export.iter_mat,
    }
    filename = f"{record.id}-{record.plant}.{fmt}"
    headers = {"content-disposition": f'attachment; filename="{filename}"'}
    parts = writers[fmt](rec)
    if accepts_gzip(request.headers.get("accept-encoding", "")):  # (as the middleware decides)
        # compressed here, in the writer's thread, part by part (zlib lets the event loop
        # run meanwhile): the middleware would compress on the event loop, tens of ms a
        # part, and passes a response that says its encoding
        parts = _gzipped(parts)
        headers |= {"content-encoding": "gzip", "vary": "Accept-Encoding"}
    return StreamingResponse(
        _while_downloading(m, record.id, parts), media_type=FORMATS[fmt], headers=headers
    )


def _gzipped(parts: Iterator[bytes]) -> Iterator[bytes]:
    """``parts`` as one gzip stream (RFC 1952) at :data:`GZIP_LEVEL`, a part at a time."""
    z = zlib.compressobj(GZIP_LEVEL, zlib.DEFLATED, 16 + zlib.MAX_WBITS)
    for part in parts:
        out = z.compress(part)
        if out:
            yield out
    yield z.flush()


async def _while_downloading(
    m: RunManager, run_id: str, parts: Iterator[bytes]
) -> AsyncIterator[bytes]:
    """The parts, written in a worker thread, with the run kept in the store until the
    last one (a run deleted meanwhile goes after)."""
    with m.downloading(run_id):
        async for part in iterate_in_threadpool(parts):
            yield part


def _header(record: RunRecord) -> dict[str, str]:
    asked = convert.requested(record)
    header = {
        "run": record.id,
        "plant": record.plant,
        "mode": record.mode,
        "experiment": record.experiment,
        "status": record.status,
        "owner": display_name(record.owner),
        "reason": record.error or "",
        "controller": _compact(asked.controller),
        "signal": _compact(asked.signal),
        **export.sensors_header(get_plant(record.plant), asked.seed, asked.quantize),
        "generator": "elab serve",
    }
    if record.error:  # who stopped it and why, why it failed or was interrupted
        header["reason"] = record.error
    if record.outcome:  # what "finished" alone would hide, each with where it began
        header["outcome"] = "; ".join(m["text"] for m in record.outcome)
    return header


def _compact(obj: Any) -> str:
    if obj is None:
        return "plant default"
    return json.dumps(obj, separators=(",", ":"))
