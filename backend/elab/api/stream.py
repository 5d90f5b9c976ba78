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
from collections.abc import Awaitable, Callable, Mapping
from typing import Any

import anyio
import msgpack
from pydantic import TypeAdapter, ValidationError
from starlette.types import Receive, Scope, Send
from starlette.websockets import WebSocket, WebSocketDisconnect

from elab.api import schemas as s
from elab.api.frames import pack
from elab.api.http import error_detail, query_int
from elab.api.runs import apply_params, run_info
from elab.errors import ElabError, InvalidInput, NotFound
from elab.runs.fanout import Watcher

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
        await ws.close(s.CloseCode.BAD_REQUEST, f"use the websocket subprotocol {s.PROTOCOL}")
        return
    m = ws.app.state.manager
    try:
        from_seq = query_int(ws, "from_seq", -1, 0, 2**62)
        record = await m.get(ws.path_params["run_id"])
    except (NotFound, InvalidInput) as exc:
        await ws.accept(subprotocol=s.PROTOCOL)
        code = s.CloseCode.NOT_FOUND if isinstance(exc, NotFound) else s.CloseCode.BAD_REQUEST
        await ws.close(code, str(exc)[:120])  # a close reason holds 123 bytes
        return
    await ws.accept(subprotocol=s.PROTOCOL)
    channel = m.channel(record)
    watcher = Watcher(send_bytes, m.codec, max_frames=ws.app.state.settings.watcher_frames)
    try:
        info = await run_info(ws, record)
        await ws.send_bytes(pack(s.Hello(run=info, live_seq=channel.edge // channel.F)))
        channel.watchers.add(watcher)
        if from_seq >= 0 or channel.ended:  # a finished run replays from its start
            channel.resume_from(watcher, max(from_seq, 0))
        if channel.ended:
            channel.tell(watcher, m.codec.status(record.status, record.n_stored, record.error))
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


async def _send(channel: Any, watcher: Watcher, scope: anyio.CancelScope) -> None:
    with contextlib.suppress(OSError, RuntimeError):  # from the raw send, as the Sender's
        await channel.serve(watcher)
    scope.cancel()  # the client went away (or a send to it failed): stop receiving too


async def _receive(ws: WebSocket, m: Any, run_id: str, channel: Any, watcher: Watcher) -> None:
    while True:
        message = await ws.receive()
        if message["type"] == "websocket.disconnect":
            return
        try:
            await _handle(_message(message), m, run_id, channel, watcher)
        except (ValidationError, ElabError, ValueError) as exc:
            channel.tell(watcher, pack(_error(exc)))


def _message(message: Mapping[str, Any]) -> Any:
    """A client message: msgpack (binary) or JSON (text), validated. Both parsers bound
    the nesting (msgpack's StackError, pydantic's recursion limit) and the numbers (64-bit
    in msgpack; pydantic refuses out-of-range JSON numbers): a ValueError at worst."""
    raw = message.get("bytes")
    if raw is not None:
        return CLIENT.validate_python(msgpack.unpackb(raw))
    return CLIENT.validate_json(message.get("text") or "")


async def _handle(msg: Any, m: Any, run_id: str, channel: Any, watcher: Watcher) -> None:
    if isinstance(msg, s.ResumeFrom):
        channel.resume_from(watcher, msg.seq)
    elif isinstance(msg, s.SetParams):
        await apply_params(m, run_id, msg.controller, msg.signal)
    else:
        await m.control(run_id, msg.type)


def _error(exc: Exception) -> s.ErrorMessage:
    if isinstance(exc, ValidationError | ElabError):
        _, detail = error_detail(exc)
        return s.ErrorMessage(code=detail.code, message=detail.message, field=detail.field)
    return s.ErrorMessage(code="invalid", message=f"not a message: {exc}", field=None)
