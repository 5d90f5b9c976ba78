"""``/runs/{id}/stream``: the live websocket (subprotocol ``elab.v1``, msgpack).

A receiver and a sender run in one task group (encode/broadcaster's pattern):
the sender drains the watcher's queue (:mod:`elab.runs.fanout`), the receiver
validates each client message against :data:`~elab.api.schemas.ClientMessage`
and answers a bad one with an ``error`` message, keeping the connection.
Query ``from_seq=N`` starts the watcher at frame N from the recording
(default: the live edge for a running run, 0 for a finished one).
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Awaitable, Callable
from typing import Any

import anyio
import msgpack
from pydantic import TypeAdapter, ValidationError
from starlette.types import Receive, Scope, Send
from starlette.websockets import WebSocket, WebSocketDisconnect

from elab.api import schemas as s
from elab.api.frames import pack
from elab.api.http import error_detail
from elab.api.runs import apply_params, run_info
from elab.errors import ElabError, NotFound
from elab.runs.fanout import Watcher

CLOSE_NOT_FOUND = 4404
CLOSE_BAD_PROTOCOL = 4400
CLIENT = TypeAdapter(s.ClientMessage)


class Stream:
    """The route's ASGI app. Frames go to the server's ``send`` as they are, past
    starlette's per-message state checks (6 µs of the 45 µs a message cost in the
    send path; docs/benchmarks.md); the handshake and the rest use starlette's
    :class:`WebSocket`."""

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        async def send_bytes(payload: bytes) -> None:
            await send({"type": "websocket.send", "bytes": payload})

        await stream(WebSocket(scope, receive, send), send_bytes)


async def stream(ws: WebSocket, send_bytes: Callable[[bytes], Awaitable[None]]) -> None:
    if s.PROTOCOL not in ws.scope.get("subprotocols", []):
        await ws.accept()
        await ws.close(CLOSE_BAD_PROTOCOL, f"use the websocket subprotocol {s.PROTOCOL}")
        return
    m = ws.app.state.manager
    try:
        record = await m.get(ws.path_params["run_id"])
    except NotFound as exc:
        await ws.accept(subprotocol=s.PROTOCOL)
        await ws.close(CLOSE_NOT_FOUND, str(exc)[:120])
        return
    await ws.accept(subprotocol=s.PROTOCOL)
    channel = m.channel(record)
    watcher = Watcher(send_bytes, m.codec, max_frames=ws.app.state.settings.watcher_frames)
    info = await run_info(ws, record)
    await ws.send_bytes(pack(s.Hello(run=info, live_seq=channel.edge // channel.F)))
    channel.watchers.add(watcher)
    start = _start_seq(ws, channel.edge // channel.F, record.status)
    if start is not None:
        channel.resume_from(watcher, start)
    if channel.ended:
        channel.tell(watcher, m.codec.status(record.status, record.n_stored, record.error))
    try:
        async with anyio.create_task_group() as tg:
            tg.start_soon(_send, channel, watcher, tg.cancel_scope)
            await _receive(ws, m, record.id, channel, watcher)
            tg.cancel_scope.cancel()
    except (WebSocketDisconnect, anyio.ClosedResourceError):
        pass
    finally:
        watcher.closed = True
        channel.watchers.discard(watcher)
        m.release(record.id, channel)


def _start_seq(ws: WebSocket, live_seq: int, status: str) -> int | None:
    raw = ws.query_params.get("from_seq")
    if raw is not None and raw.isdigit():
        return int(raw)
    return 0 if status not in ("running", "paused", "created") else None


async def _send(channel: Any, watcher: Watcher, scope: anyio.CancelScope) -> None:
    with contextlib.suppress(OSError, RuntimeError):  # from the raw send, as the Sender's
        await channel.serve(watcher)
    scope.cancel()  # the client went away (or a send to it failed): stop receiving too


async def _receive(ws: WebSocket, m: Any, run_id: str, channel: Any, watcher: Watcher) -> None:
    while True:
        message = await ws.receive()
        if message["type"] == "websocket.disconnect":
            return
        raw = message.get("bytes") or message.get("text") or b""
        try:
            data = msgpack.unpackb(raw) if isinstance(raw, bytes) else _json(raw)
            await _handle(CLIENT.validate_python(data), m, run_id, channel, watcher)
        except (ValidationError, ElabError, ValueError) as exc:
            channel.tell(watcher, pack(_error(exc)))


async def _handle(msg: Any, m: Any, run_id: str, channel: Any, watcher: Watcher) -> None:
    if isinstance(msg, s.ResumeFrom):
        channel.resume_from(watcher, msg.seq)
    elif isinstance(msg, s.SetParams):
        await apply_params(m, run_id, msg.controller, msg.signal)
    else:
        await m.control(run_id, msg.type)


def _json(text: str) -> Any:
    return json.loads(text)


def _error(exc: Exception) -> s.ErrorMessage:
    if isinstance(exc, ValidationError | ElabError):
        _, detail = error_detail(exc)
        return s.ErrorMessage(code=detail.code, message=detail.message, field=detail.field)
    return s.ErrorMessage(code="invalid", message=f"not a message: {exc}", field=None)
