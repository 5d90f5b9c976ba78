"""Identification over HTTP: ``POST /api/v1/ident`` runs :func:`elab.ident.workflow.run`
on a run's recording or on an uploaded table (validated on its rest or on a separate
record: :mod:`elab.api.identdata`) and answers with every result as JSON
(:mod:`elab.api.identjson`).

With ``Accept: application/x-ndjson`` the answer is a stream of lines, ``{"progress":
{"stage", "done"}}`` while it works, then ``{"result": …}`` or ``{"error": …}``. The data
are checked before anything is computed, so bad data get a 422 in either mode; only an
error found while estimating arrives as the stream's last line. Nothing is stored.

The work runs in the server's identification workers (:mod:`elab.jobs`): at most
``ELAB_IDENT_WORKERS`` at once, each within ``ELAB_IDENT_TIMEOUT`` seconds, a request
waiting for a worker at most ``ELAB_IDENT_WAIT`` seconds (then 429); a request whose
client goes away stops its job. An uploaded table is parsed by a worker before the stream
starts (bad data: 422 in either mode), so that wait has no progress line.
"""

from __future__ import annotations

import asyncio
from collections import Counter
from collections.abc import AsyncIterator, Callable, Coroutine
from functools import partial
from typing import Any, TypeVar

from starlette.background import BackgroundTask
from starlette.requests import Request
from starlette.responses import Response, StreamingResponse

from elab.api import identjson, preload
from elab.api import schemas as s
from elab.api.auth import identity
from elab.api.convert import Requested
from elab.api.http import endpoint, error_detail, read_model
from elab.api.identdata import records
from elab.api.state import lab
from elab.errors import ElabError, InvalidInput, TooMany
from elab.ident import IdData
from elab.ident import workflow as wf
from elab.ident.closedloop import Controller, References
from elab.ident.files import Table, read_table
from elab.ident.modeladvice import Physics, physics_of
from elab.jobs import JobPool
from elab.plants import get_plant

# what the identification workers import before they take a job (elab.jobs)
JOB_MODULES = preload.IDENT

T = TypeVar("T")


@endpoint(
    "POST",
    "/ident",
    body=s.IdentRequest,
    response=s.IdentOut,
    errors=(404, 413, 422, 429, 503),
    stream=s.IdentLine,
)
async def identify(request: Request) -> Response:
    """Identify models from a run's data or an uploaded table

    Correlation, spectral and sine analysis, ARX order search, subspace singular values
    and the requested ARX, ARMAX, OE and n4sid models with their validation fit % and
    residual analysis (see docs/identification.md), validated on the rest of the data or on
    a separate ``validation`` record. The body, both records in it, may be as large as
    ``ELAB_MAX_UPLOAD`` (16 MiB)."""
    req = await read_model(request, s.IdentRequest, upload=True)
    if req.indirect is not None and req.two_stage is not None:  # before any data are read
        raise InvalidInput(
            "indirect", "with two_stage", "one closed-loop method at a time: two_stage or indirect"
        )
    slot = _slots(request).take(identity(request).id)
    mine: Callable[[], None] | None = slot
    try:
        got = await records(request, req, partial(_parse, request))
        plan = _plan(req, got.ran, _physics(got.data, got.ran), _rest(req, got.data, got.ran))
        work = (got.data, plan, got.validation, got.references)
        if "application/x-ndjson" in request.headers.get("accept", ""):
            mine = None  # given back when the stream ends, however it ends
            lines = _progress_lines(jobs(request), work, slot)
            return StreamingResponse(
                lines, media_type="application/x-ndjson", background=BackgroundTask(slot)
            )
        job = jobs(request).run(identjson.identify, *work)
        result = await _unless_gone(request, job)
        if result is None:
            raise ClientGone
    except ClientGone:
        return Response(status_code=499)  # nginx's "client closed request": nobody reads it
    finally:
        if mine is not None:
            mine()
    return Response(result, media_type="application/json")


class IdentSlots:
    """Identifications under way per identity (``ELAB_MAX_IDENT_PER_IDENTITY``): one
    browser cannot occupy every worker."""

    def __init__(self, per_identity: int) -> None:
        self.per_identity = per_identity
        self.by: Counter[str] = Counter()

    def take(self, who: str) -> Callable[[], None]:
        """A slot for ``who`` (:class:`TooMany` if they have all theirs); call the result
        to give it back."""
        if who and self.by[who] >= self.per_identity:
            raise TooMany(
                f"you have {self.by[who]} identifications under way, the limit per identity "
                f"(ELAB_MAX_IDENT_PER_IDENTITY = {self.per_identity}); retry when one is done",
                retry_after=5.0,
            )
        self.by[who] += 1
        done = False

        def give_back() -> None:
            nonlocal done
            if not done:
                done = True
                self.by[who] -= 1
                if self.by[who] <= 0:
                    del self.by[who]

        return give_back


def _slots(request: Request) -> IdentSlots:
    return lab(request).ident_slots


class ClientGone(Exception):
    """The client went away while its request was worked on: nobody to answer."""


def jobs(request: Request) -> JobPool:
    return lab(request).jobs


async def _unless_gone(request: Request, job: Coroutine[Any, Any, T]) -> T | None:
    """The job's result, or ``None`` (and the job stopped) if the client goes away first."""
    work = asyncio.ensure_future(job)
    gone = asyncio.ensure_future(_disconnected(request))
    try:
        await asyncio.wait({work, gone}, return_when=asyncio.FIRST_COMPLETED)
    finally:
        gone.cancel()
    if not work.done():
        work.cancel()
        await asyncio.gather(work, return_exceptions=True)
        return None
    return work.result()


async def _disconnected(request: Request) -> None:
    """Until the client disconnects (its body has been read: nothing else can come)."""
    while (await request.receive())["type"] != "http.disconnect":
        pass


async def _progress_lines(
    pool: JobPool,
    work: tuple[IdData, wf.Plan, IdData | None, References | None],
    release: Callable[[], None],
) -> AsyncIterator[bytes]:
    """Progress, then the result of :func:`identjson.identify` on ``work`` (data, plan,
    validation, references): the job's reports as they come. When the client goes away, the response
    is cancelled here, which stops the job."""
    queue: asyncio.Queue[tuple[str, float]] = asyncio.Queue()
    job = asyncio.ensure_future(
        pool.run(
            identjson.identify,
            *work,
            progress=lambda stage, done: queue.put_nowait((stage, done)),
        )
    )
    try:
        while not job.done() or not queue.empty():
            getter = asyncio.ensure_future(queue.get())
            await asyncio.wait({job, getter}, return_when=asyncio.FIRST_COMPLETED)
            if getter.done():
                stage, done = getter.result()
                progress = s.IdentProgress(stage=stage, done=round(min(max(done, 0.0), 1.0), 3))
                yield _line(s.IdentLine(progress=progress))
            else:
                getter.cancel()
        try:  # the result is JSON already (written by the worker): not parsed again here
            yield b'{"progress":null,"result":' + job.result().encode() + b',"error":null}\n'
        except ElabError as exc:
            yield _line(s.IdentLine(error=error_detail(exc)[1]))
    finally:
        job.cancel()
        release()


def _line(line: s.IdentLine) -> bytes:
    return line.model_dump_json().encode() + b"\n"


async def _parse(request: Request, text: bytes, fmt: str, max_rows: int, why: str) -> Table:
    """A file's table, parsed by a worker: a huge file stalls no stream."""
    job = jobs(request).run(read_table, text, fmt, max_rows, why)
    table = await _unless_gone(request, job)
    if table is None:
        raise ClientGone
    return table


def _physics(data: IdData, ran: Requested | None) -> Physics | None:
    """The run's plant model from u to the data's outputs, where the data are a run's
    plant input and outputs (nominal for a run on the real rig)."""
    if ran is None or data.input_names != ("u",):
        return None
    return physics_of(get_plant(ran.plant), data.output_names, data.Ts, ran.rig)


def _rest(
    req: s.IdentRequest, data: IdData, ran: Requested | None
) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
    """The data's channels at the run's plant's rest (its operating point, u = 0), for
    ``detrend: "operating_point"``; None for a file (the workflow then refuses it)."""
    if req.detrend != "operating_point" or ran is None:
        return None
    rest = get_plant(ran.plant).rest
    for name in (*data.output_names, *data.input_names):
        if name not in rest:  # a rig run's latency, say: not a signal of the plant
            raise InvalidInput(
                "detrend",
                f"operating_point with the channel {name!r}",
                f"another detrend, or channels the plant rests at: {', '.join(rest)}",
            )
    return tuple(rest[n] for n in data.output_names), tuple(rest[n] for n in data.input_names)


def _plan(
    req: s.IdentRequest,
    ran: Requested | None,
    physics: Physics | None = None,
    rest: tuple[tuple[float, ...], tuple[float, ...]] | None = None,
) -> wf.Plan:
    def span(name: str, v: list[int]) -> range:
        if v[0] > v[1]:
            raise InvalidInput(name, v, "[lowest, highest] with lowest ≤ highest")
        return range(v[0], v[1] + 1)

    search = None
    if req.arx_search is not None:
        a = req.arx_search
        search = (
            span("arx_search.na", a.na),
            span("arx_search.nb", a.nb),
            span("arx_search.nk", a.nk),
        )
        if a.nb[0] < 1:
            raise InvalidInput("arx_search.nb", a.nb, "orders ≥ 1")
        count = len(search[0]) * len(search[1]) * len(search[2])
        if count > wf.MAX_SEARCH:
            raise InvalidInput(
                "arx_search",
                f"{count} structures",
                f"at most {wf.MAX_SEARCH} structures (na × nb × nk)",
            )
    orders = None if req.n4sid_orders is None else span("n4sid_orders", req.n4sid_orders)
    if orders is not None and orders.start < 1:
        raise InvalidInput("n4sid_orders", req.n4sid_orders, "orders ≥ 1")
    models = tuple(
        wf.ModelRequest(m.kind, {k: v for k, v in m.model_dump().items() if k != "kind"})
        for m in req.models
    )
    return wf.Plan(
        models=models,
        detrend=req.detrend,
        split=req.split,
        correlation=req.correlation,
        max_lag=req.max_lag,
        spectral=req.spectral,
        sine_hz=req.sine_hz if req.sine_hz is not None else ran.sine_hz if ran else None,
        arx_search=search,
        n4sid_orders=orders,
        horizon=req.horizon,
        closed_loop=None if ran is None else ran.closed_loop,
        decimate=req.decimate,
        physics=physics,
        two_stage=req.two_stage,
        indirect=None
        if req.indirect is None
        else Controller(tuple(req.indirect.num), tuple(req.indirect.den)),
        operating_point=rest,
    )
