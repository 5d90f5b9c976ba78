"""HTTP plumbing: the endpoint registry (routes and OpenAPI come from it), JSON
bodies with a size limit, responses from models, and errors as JSON.

Status codes: 422 invalid input (every field error listed), 404 unknown id,
401 an unknown API token or a wrong password, 403 not yours to change (or a
request from another site), 409 conflict with the current state, 413 body too
large, 415 a body that is not JSON, 429 a limit on concurrent work or storage
(with ``Retry-After``), 503 a part of the server is down or failing (the
engine, the store; with ``Retry-After`` when it is worth retrying).
Every error body is ``{"error": {"code", "message", "field", "errors"}}``.
"""

from __future__ import annotations

import asyncio
import json
import math
import re
from collections import Counter
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
from pydantic import BaseModel, ValidationError
from starlette.datastructures import Headers
from starlette.middleware.gzip import GZipMiddleware
from starlette.requests import HTTPConnection, Request
from starlette.responses import JSONResponse, Response
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from elab.api.schemas.errors import ErrorBody, ErrorCode, ErrorDetail, FieldError
from elab.api.state import lab
from elab.errors import (
    Conflict,
    ElabError,
    Forbidden,
    InvalidInput,
    NotFound,
    TooMany,
    Unauthorized,
    Unavailable,
)
from elab.validate import computable

Handler = Callable[[Request], Awaitable[Response]]
M = TypeVar("M", bound=BaseModel)
R = TypeVar("R")


class TooLarge(ElabError):
    """A request body over the configured limit."""

    def __init__(self, limit: int, setting: str = "ELAB_MAX_BODY") -> None:
        super().__init__(f"request body is larger than {limit} bytes ({setting})")


class SlowBody(ElabError):
    """A request body that stopped coming (HTTP 408)."""

    def __init__(self, seconds: float) -> None:
        super().__init__(
            f"the request body stopped coming: nothing for {seconds:g} s (ELAB_BODY_TIMEOUT); "
            "send it again"
        )


class BodyTimeout:
    """ASGI middleware: while a request's body is being received, each part must come
    within ``seconds`` (``ELAB_BODY_TIMEOUT``), else :class:`SlowBody` (408). A client that
    declares a body and never sends it would otherwise hold its upload slot for ever (issue
    24: four such connections held every ``ELAB_MAX_UPLOADS`` slot). Once the body is in,
    ``receive`` waits as long as it likes (for a disconnect during a download)."""

    def __init__(self, app: ASGIApp, seconds: float) -> None:
        self.app = app
        self.seconds = seconds

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        done = False

        async def timed() -> Message:
            nonlocal done
            if done:
                return await receive()
            try:
                message = await asyncio.wait_for(receive(), self.seconds)
            except TimeoutError:
                raise SlowBody(self.seconds) from None
            done = message["type"] != "http.request" or not message.get("more_body", False)
            return message

        await self.app(scope, timed, send)


@dataclass(frozen=True)
class Param:
    """A path or query parameter, for the OpenAPI document (a path's own are declared once,
    in :mod:`elab.api.paths`)."""

    name: str
    where: str  # "path" | "query"
    description: str
    schema: dict[str, Any] = field(default_factory=lambda: {"type": "string"})
    required: bool = False


@dataclass(frozen=True)
class Endpoint:
    method: str
    path: str
    summary: str
    handler: Handler
    description: str | None = None
    body: type[BaseModel] | None = None
    response: Any = None
    status: int = 200
    params: tuple[Param, ...] = ()  # query parameters (a path's own follow from the path)
    errors: tuple[int, ...] = (404, 422)
    media: str = "application/json"
    stream: type[BaseModel] | None = None  # answered as NDJSON lines of this model on request
    # operations that take the id this one returns (OpenAPI links: clients and fuzzers follow
    # them): (operationId, its path parameter)
    links: tuple[tuple[str, str], ...] = ()
    form: dict[str, Any] | None = None  # a multipart/form-data body it also takes (schema)
    # a file response's media types (default: a run's recording: CSV, .mat, JSON)
    files: tuple[str, ...] = ()


#: gzip of the responses made at request time (JSON by the middleware, downloads by
#: their own writer thread), not of the assets (the build's level 9, api/assets.py). A 16 MB
#: CSV: level 1 compresses at 89 MB/s to 1/2.67, level 9 (starlette's default) at 9 MB/s to
#: 1/2.99; the 11 % more bytes take less time to send than level 9's extra compression on
#: any link faster than about 3 Mbit/s (docs/benchmarks.md, downloads).
GZIP_LEVEL = 1
ENDPOINTS: list[Endpoint] = []


def accepts_gzip(accept_encoding: str) -> bool:
    """Whether an ``Accept-Encoding`` header takes gzip (RFC 9110, 12.5.3): ``gzip`` (or
    ``x-gzip``) listed with a weight above 0, or not listed and ``*`` with one. ``gzip;q=0``
    refuses it, though the word is there (starlette's middleware looks for the word only);
    an unreadable weight counts as 0 (the plain response is always acceptable)."""
    weights: dict[str, float] = {}
    for item in accept_encoding.split(","):
        name, *params = (part.strip().lower() for part in item.split(";"))
        q = 1.0
        for param in params:
            key, _, value = param.partition("=")
            if key.strip() == "q":
                try:
                    q = float(value)
                except ValueError:
                    q = 0.0
        if name:
            weights[name] = q if math.isfinite(q) else 0.0
    for name in ("gzip", "x-gzip"):
        if name in weights:
            return weights[name] > 0
    return weights.get("*", 0.0) > 0


class GZip(GZipMiddleware):
    """starlette's gzip middleware, with a refusal (``gzip;q=0``) read as one
    (:func:`accepts_gzip`)."""

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and not accepts_gzip(
            Headers(scope=scope).get("accept-encoding", "")
        ):
            await self.app(scope, receive, send)  # as it is
            return
        await super().__call__(scope, receive, send)


def endpoint(
    method: str, path: str, summary: str | None = None, **meta: Any
) -> Callable[[Handler], Handler]:
    """Register ``handler`` under ``/api/v1`` + ``path``. Its docstring says what it does:
    the first paragraph is the summary, the rest the description (a generated handler,
    without one, is given its ``summary``)."""

    def register(handler: Handler) -> Handler:
        words, description = summary, " ".join((handler.__doc__ or "").split()) or None
        if words is None:
            first, _, rest = (handler.__doc__ or "").strip().partition("\n\n")
            words, description = " ".join(first.split()), " ".join(rest.split()) or None
        if not words:
            raise TypeError(f"endpoint {method} {path}: its handler has no docstring to sum it up")
        ENDPOINTS.append(Endpoint(method, path, words, handler, description, **meta))
        return handler

    return register


async def read_model(request: Request, model: type[M], upload: bool = False) -> M:
    """The body as ``model``: 413 over the limit (``upload``: the larger upload limit),
    422 for bad JSON or fields. The JSON is parsed by pydantic's parser, which bounds the
    nesting (200 levels) and the size of numbers, so no body can crash the parser."""
    body = await read_body(request, upload)
    return model.model_validate_json(body)


class Uploads:
    """How many large bodies are being read at once, in all (``ELAB_MAX_UPLOADS``) and
    per identity (``ELAB_MAX_UPLOADS_PER_IDENTITY``)."""

    def __init__(self, limit: int, per_identity: int | None = None) -> None:
        self.limit = limit
        self.per_identity = per_identity or limit
        self.reading = 0
        self.by: Counter[str] = Counter()

    @contextmanager
    def slot(self, who: str = "") -> Iterator[None]:
        if self.by[who] >= self.per_identity and who:
            raise TooMany(
                f"you are sending {self.by[who]} uploads at once, the limit per identity "
                f"(ELAB_MAX_UPLOADS_PER_IDENTITY = {self.per_identity}); retry when one is "
                "done",
                retry_after=2.0,
            )
        if self.reading >= self.limit:
            raise TooMany(
                f"{self.reading} uploads are being received, the limit of this "
                f"server (ELAB_MAX_UPLOADS = {self.limit}); retry shortly",
                retry_after=2.0,
            )
        self.reading += 1
        self.by[who] += 1
        try:
            yield
        finally:
            self.reading -= 1
            self.by[who] -= 1
            if not self.by[who]:
                del self.by[who]


async def read_body(request: Request, upload: bool = False) -> bytes:
    """The raw body, refused with 413 past ``ELAB_MAX_BODY`` (``upload``: ``ELAB_MAX_UPLOAD``,
    and 429 while ``ELAB_MAX_UPLOADS`` others are being received) before it is all read."""
    settings = lab(request).settings
    limit: int = settings.max_upload if upload else settings.max_body
    setting = "ELAB_MAX_UPLOAD" if upload else "ELAB_MAX_BODY"
    length = request.headers.get("content-length")
    if length is not None and length.isascii() and length.isdigit() and int(length) > limit:
        raise TooLarge(limit, setting)
    who = request.scope.get("elab.identity")
    uploads = lab(request).uploads
    with uploads.slot(who.id if who is not None else "") if upload else nullcontext():
        body = bytearray()
        async for part in request.stream():
            body += part
            if len(body) > limit:
                raise TooLarge(limit, setting)
    return bytes(body)


def computed(
    f: Callable[..., R], *args: Any, field: str = "controller", value: Any = "these gains"
) -> R:
    """``f(*args)`` on a client's numbers, with a numerical failure (numbers that overflow
    double precision) as the input's fault, naming ``field``: 422, not 500. A result with a
    number JSON cannot hold (inf, NaN where the schema has none) is such a failure too."""
    allowed = "numbers whose result can be computed in double precision"
    with computable(field, value, allowed), np.errstate(all="ignore"):
        out = f(*args)
        if isinstance(out, BaseModel):
            try:
                out.model_dump_json()
            except ValueError:
                raise InvalidInput(field, value, f"{allowed} (it overflowed)") from None
    return out


class Pending:
    """Creations under way per (kind, identity): a budget counts them with what is stored,
    so requests at once cannot all pass the check before any of them has stored."""

    def __init__(self) -> None:
        self.n: Counter[tuple[str, str]] = Counter()

    @contextmanager
    def hold(self, kind: str, who: str) -> Iterator[int]:
        """While one is being made; yields how many others of ``who`` are."""
        key = (kind, who)
        self.n[key] += 1
        try:
            yield self.n[key] - 1
        finally:
            self.n[key] -= 1
            if not self.n[key]:
                del self.n[key]


def within_budget(have: int, limit: int, what: str, setting: str) -> None:
    """:class:`TooMany` once an identity keeps ``limit`` of something (``what``: "API
    tokens"), naming the setting; it gains room by deleting one."""
    if have >= limit:
        raise TooMany(
            f"you have {have} {what}, the limit per identity ({setting} = {limit}); "
            "delete one first",
            retry_after=60.0,
        )


def ok(model: BaseModel | list[Any], status: int = 200) -> JSONResponse:
    if isinstance(model, list):
        return JSONResponse([m.model_dump(mode="json") for m in model], status_code=status)
    return JSONResponse(model.model_dump(mode="json"), status_code=status)


def error_response(exc: Exception) -> JSONResponse:
    """The JSON error for a known exception (anything else is a bug: 500)."""
    status, detail = error_detail(exc)
    retry = getattr(exc, "retry_after", None)
    headers = {"retry-after": str(max(1, math.ceil(retry)))} if retry is not None else None
    return JSONResponse(
        ErrorBody(error=detail).model_dump(mode="json"), status_code=status, headers=headers
    )


def error_detail(exc: Exception) -> tuple[int, ErrorDetail]:
    """Status code and body of a known exception (re-raises anything else)."""
    if isinstance(exc, ValidationError):
        # a value that may only be omitted (``X | SkipJsonSchema[None]``) fails as X and as
        # null: the second says nothing the first does not
        found = [e for e in exc.errors() if e["type"] != "none_required"] or exc.errors()
        errors = [FieldError(field=_loc(e["loc"]), message=_msg(e)) for e in found[:20]]
        return 422, ErrorDetail(
            code="invalid",
            message="; ".join(f"{e.field}: {e.message}" for e in errors),
            field=errors[0].field if errors else None,
            errors=errors,
        )
    if isinstance(exc, InvalidInput):
        return 422, ErrorDetail(
            code="invalid",
            message=str(exc),
            field=exc.field,
            errors=[FieldError(field=exc.field, message=str(exc))],
        )
    for kind, status, code in _STATUS:
        if isinstance(exc, kind):
            return status, ErrorDetail(code=code, message=str(exc))
    raise exc


#: the other errors' status codes and codes, the first that matches
_STATUS: tuple[tuple[type[ElabError], int, ErrorCode], ...] = (
    (NotFound, 404, "not_found"),
    (Conflict, 409, "conflict"),
    (Forbidden, 403, "forbidden"),
    (Unauthorized, 401, "unauthorized"),
    (TooMany, 429, "too_many"),
    (TooLarge, 413, "too_large"),
    (SlowBody, 408, "timeout"),
    (Unavailable, 503, "unavailable"),
)


def _loc(loc: tuple[int | str, ...]) -> str:
    """``signal.square.amplitude``: without pydantic's name of a union inside a union."""
    return ".".join(str(p) for p in loc if not str(p).startswith("tagged-union[")) or "body"


def _msg(e: Any) -> str:
    raw = e.get("input")
    if isinstance(raw, bytes | bytearray):  # the body itself (it was not valid JSON)
        raw = bytes(raw[:80]).decode("utf-8", "replace")
    value = json.dumps(raw, default=str)
    value = value if len(value) <= 60 else value[:57] + "..."
    return f"{e['msg']} (got {value})"


def query(request: HTTPConnection, name: str) -> str | None:
    """A query parameter given at most once (a repeated one is refused, not cut to one)."""
    values = request.query_params.getlist(name)
    if len(values) > 1:
        raise InvalidInput(name, values, "one value (the parameter is repeated)")
    return values[0] if values else None


_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", re.ASCII)


def query_float(request: Request, name: str) -> float | None:
    raw = query(request, name)
    if raw is None:
        return None
    if not _DECIMAL.fullmatch(raw):  # float() would also take 1_000, ٣, inf and nan
        raise InvalidInput(name, raw, "a decimal number, e.g. 1.5 or 2e-3")
    value = float(raw)
    if value != value or value in (float("inf"), float("-inf")):
        raise InvalidInput(name, raw, "a finite number")
    return value


def query_int(request: HTTPConnection, name: str, default: int, lo: int, hi: int) -> int:
    """An integer query parameter in ``[lo, hi]`` written in ASCII digits (Python's ``int``
    would also take ``٣``, and ``"²".isdigit()`` is true)."""
    raw = query(request, name)
    if raw is None:
        return default
    digits = raw[1:] if raw[:1] == "-" else raw
    if not (digits.isascii() and digits.isdigit() and len(digits) <= 19 and lo <= int(raw) <= hi):
        raise InvalidInput(name, raw, f"an integer in [{lo}, {hi}]")
    return int(raw)
