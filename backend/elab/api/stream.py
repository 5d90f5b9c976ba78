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
import struct
from collections.abc import Awaitable, Callable, Mapping
from typing import Any, assert_never

import anyio
import msgpack
from pydantic import TypeAdapter, ValidationError
from starlette.types import ASGIApp, Receive, Scope, Send
from starlette.websockets import WebSocket, WebSocketDisconnect
from uvicorn.protocols.websockets.websockets_sansio_impl import WebSocketsSansIOProtocol
from websockets.protocol import State

from elab.access import Identity
from elab.api import schemas as s
from elab.api.auth import identity
from elab.api.frames import pack
from elab.api.http import error_detail, query_int
from elab.api.rig import rig_desk
from elab.api.runs import apply_params, run_info
from elab.api.state import lab
from elab.errors import ElabError, InvalidInput, NotFound, TooMany
from elab.runs.fanout import Watcher

CLIENT = TypeAdapter(s.ClientMessage)


RAW_SEND = "elab.send"  # the scope key of the server's own send (set by RawSend)


class RawSend:
    """Middleware (outermost): keeps the ASGI server's own ``send`` of a websocket in
    the scope, before starlette's layers wrap it, for :func:`direct_writer`."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "websocket":
            scope[RAW_SEND] = send
        await self.app(scope, receive, send)


class Stream:
    """The route's ASGI app. Frames go to the server's ``send`` as they are, past
    starlette's per-message state checks (6 µs of the 45 µs a message cost in the
    send path; docs/benchmarks.md), and straight to the connection where the server
    allows (:func:`direct_writer`); the handshake and the rest use starlette's
    :class:`WebSocket`."""

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        async def send_bytes(payload: bytes) -> None:
            await send({"type": "websocket.send", "bytes": payload})

        write = direct_writer(scope.get(RAW_SEND))
        await stream(WebSocket(scope, receive, send), send_bytes, write)


def direct_writer(send: Any) -> Callable[[bytes], bool] | None:
    """A function writing a binary message straight to the connection of uvicorn's
    sans-I/O websocket protocol (its default), as ``websockets.broadcast()`` writes to its
    own connections, with no coroutine and no ASGI message; the websocket frame of a
    message is built once for all the watchers it goes to (:func:`binary_frame`). It
    writes only what uvicorn's ``send`` would write at once (the connection open with no
    extension, the transport not paused) and otherwise returns ``False``, so the caller
    falls back to ``send``, which waits for room; order is kept because both write
    synchronously. ``None`` for any other server (then every message goes through
    ``send``). At 300 watchers the ASGI path cost a quarter of the web process's CPU
    (docs/benchmarks.md); tests/unit/runs/test_fanout.py checks uvicorn still fits."""
    proto = getattr(send, "__self__", None)
    if not isinstance(proto, WebSocketsSansIOProtocol):
        return None
    conn, writable = proto.conn, proto.writable

    def write(payload: bytes) -> bool:
        if (
            not writable.is_set()
            or proto.close_sent
            or proto.disconnected
            or conn.state is not State.OPEN
            or conn.extensions
            or conn.expect_continuation_frame
        ):
            return False
        transport = proto.transport
        if transport.is_closing():
            return False
        transport.write(_framed(payload))
        return True

    return write


def binary_frame(payload: bytes) -> bytes:
    """A server's binary websocket message as one frame (RFC 6455 §5.2: final, unmasked)."""
    n = len(payload)
    if n < 126:
        head = bytes((0x82, n))
    elif n < 1 << 16:
        head = struct.pack("!BBH", 0x82, 126, n)
    else:
        head = struct.pack("!BBQ", 0x82, 127, n)
    return head + payload


class _LastFrame:
    """The frame of the last message written: a pass writes one message to every watcher
    of a run in a row, so it is framed once."""

    def __init__(self) -> None:
        self.payload: bytes | None = None
        self.frame = b""

    def __call__(self, payload: bytes) -> bytes:
        if payload is not self.payload:
            self.payload, self.frame = payload, binary_frame(payload)
        return self.frame


_framed = _LastFrame()


async def stream(
    ws: WebSocket,
    send_bytes: Callable[[bytes], Awaitable[None]],
    write: Callable[[bytes], bool] | None = None,
) -> None:
    if s.PROTOCOL not in ws.scope.get("subprotocols", []):
        await ws.accept()
        await ws.close(s.CloseCode.BAD_REQUEST, f"use the websocket subprotocol {s.PROTOCOL}")
        return
    m = lab(ws).manager
    who = identity(ws)
    streams = lab(ws).streams
    key = who.id or f"address {ws.client.host if ws.client else ''}"
    limit = lab(ws).settings.max_streams_per_identity
    try:
        from_seq = query_int(ws, "from_seq", -1, 0, 2**62)
        record = await m.get(ws.path_params["run_id"], who)
        if streams[key] >= limit:
            raise TooMany(
                f"{streams[key]} streams open, the limit per identity "
                f"(ELAB_MAX_STREAMS_PER_IDENTITY = {limit}); close one"
            )
    except (NotFound, InvalidInput, TooMany) as exc:
        await ws.accept(subprotocol=s.PROTOCOL)
        code = {NotFound: s.CloseCode.NOT_FOUND, TooMany: s.CloseCode.TOO_MANY}.get(
            type(exc), s.CloseCode.BAD_REQUEST
        )
        await ws.close(code, str(exc)[:120])  # a close reason holds 123 bytes
        return
    streams[key] += 1
    try:
        await _watch(ws, m, record, who, from_seq, send_bytes, write)
    finally:
        streams[key] -= 1
        if not streams[key]:
            del streams[key]


async def _watch(
    ws: WebSocket,
    m: Any,
    record: Any,
    who: Identity,
    from_seq: int,
    send_bytes: Callable[[bytes], Awaitable[None]],
    write: Callable[[bytes], bool] | None,
) -> None:
    await ws.accept(subprotocol=s.PROTOCOL)
    channel = m.channel(record)
    watcher = Watcher(
        send_bytes,
        m.codec,
        max_frames=lab(ws).settings.watcher_frames,
        write=write,
        who=who.id,
    )
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
            await _receive(ws, record.id, channel, watcher, who)
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


async def _receive(
    ws: WebSocket, run_id: str, channel: Any, watcher: Watcher, who: Identity
) -> None:
    while True:
        message = await ws.receive()
        if message["type"] == "websocket.disconnect":
            return
        try:
            await _handle(ws, _message(message), run_id, channel, watcher, who)
        except (ValidationError, ElabError, ValueError) as exc:
            channel.tell(watcher, pack(_error(exc)))
        if watcher.overrun:  # it sends and does not read: its answers would pile up
            await ws.close(
                s.CloseCode.NOT_READING,
                "too many answers unread: read the stream's messages, or send fewer",
            )
            return


def _message(message: Mapping[str, Any]) -> s.ClientMessage:
    """A client message: msgpack (binary) or JSON (text), validated. Both parsers bound
    the nesting (msgpack's StackError, pydantic's recursion limit) and the numbers (64-bit
    in msgpack; pydantic refuses out-of-range JSON numbers): a ValueError at worst."""
    raw = message.get("bytes")
    if raw is not None:
        return CLIENT.validate_python(msgpack.unpackb(raw))
    return CLIENT.validate_json(message.get("text") or "")


async def _handle(
    ws: WebSocket,
    msg: s.ClientMessage,
    run_id: str,
    channel: Any,
    watcher: Watcher,
    who: Identity,
) -> None:
    match msg:
        case s.ResumeFrom():
            channel.resume_from(watcher, msg.seq)
        case s.SetParams():
            await apply_params(ws, run_id, msg, who)
        case s.Pause() | s.Resume() | s.Stop():
            await lab(ws).manager.control(run_id, msg.type, who)
        case s.EmergencyStop():
            await rig_desk(ws).emergency_stop(who)
        case _:
            assert_never(msg)


def _error(exc: Exception) -> s.ErrorMessage:
    if isinstance(exc, ValidationError | ElabError):
        _, detail = error_detail(exc)
        return s.ErrorMessage(code=detail.code, message=detail.message, field=detail.field)
    return s.ErrorMessage(code="invalid", message=f"not a message: {exc}", field=None)
