"""The two load processes of the live-server benchmark (:mod:`tests.bench.server`).

``client``: one asyncio process holding every websocket (subprotocol ``elab.v1``,
msgpack), each a minimal websocket client on a bare asyncio protocol (:class:`Watch`). Each watcher waits for ``hello``, then logs for every ``frame`` the
index of its last sample and the wall time (``time.time()``) it was received,
counts samples missing between frames, overlaps, ``skipped`` notices and
``error`` messages, and closes on the final ``status`` (finished, stopped, ...).
Once every watcher has its ``hello`` it prints one JSON line ``{"ready": n}``.
At the end it writes everything to an ``.npz`` file.

``peer``: a plain ``websockets`` server that sends the same messages (a
``hello``, 20-sample msgpack frames of 8 float32 channels at 50 frames/s, a
final ``status``) to every client with :func:`websockets.asyncio.server.broadcast`,
encoding each frame once. It starts once ``--clients`` clients are connected.

Both run on uvloop, the event loop ``elab serve`` gets from uvicorn, so the peer and
E-Lab are compared on the same loop.

Run as ``python -m tests.bench.wsload client|peer ...`` from the project root.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import hashlib
import json
import math
import os
import sys
import time
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import msgpack
import numpy as np
import uvloop
from websockets.asyncio.server import ServerConnection, broadcast, serve
from websockets.uri import parse_uri

from elab.api.frames import encode_frame
from elab.runs.fanout import frame_samples


def pack(message: dict[str, Any]) -> bytes:
    return msgpack.packb(message, use_bin_type=True)  # type: ignore[no-any-return]


PROTOCOL = "elab.v1"
_GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"  # RFC 6455, section 1.3
ENDED = {"finished", "stopped", "failed", "interrupted"}
NAMES = ("r", "u", "theta", "alpha", "x_theta", "x_alpha", "x_theta_dot", "x_alpha_dot")


@dataclass
class Log:
    """What one watcher saw."""

    run: dict[str, Any] = field(default_factory=dict)  # hello["run"]
    k_last: array[int] = field(default_factory=lambda: array("q"))
    t_recv: array[float] = field(default_factory=lambda: array("d"))
    next_k: int = 0
    missing: int = 0  # samples between two frames that never came
    overlap: int = 0  # samples received twice
    skipped: int = 0
    errors: int = 0
    end_state: str = ""
    end_k: int = -1

    def frame(self, k0: int, n: int, t: float) -> None:
        self.k_last.append(k0 + n - 1)
        self.t_recv.append(t)
        if k0 > self.next_k:
            self.missing += k0 - self.next_k
        elif k0 < self.next_k:
            self.overlap += self.next_k - k0
        self.next_k = max(self.next_k, k0 + n)


class Watch(asyncio.Protocol):
    """One watcher: a minimal RFC 6455 client on a bare asyncio protocol.

    The measuring instrument has to cost far less than what it measures: with
    ``websockets``' clients (asyncio or sans-I/O) one process spent 0.8–1 core on
    15,000 messages per second, competing with the server for the 2 cores. Here a
    message costs a header parse, a slice and ``msgpack.unpackb``. Server frames are
    unmasked and unfragmented (checked); the client sends its handshake, pongs to
    the server's keepalive pings, and a masked close frame. A close from the server
    before the run ends counts as an error. A message's receipt time is when its bytes reached the
    process (``data_received``).
    """

    def __init__(self, url: str, log: Log) -> None:
        self.uri = parse_uri(url)
        self.log = log
        self.key = base64.b64encode(os.urandom(16)).decode()
        self.buf = bytearray()
        self.open = False
        self.transport: asyncio.Transport | None = None
        loop = asyncio.get_running_loop()
        self.opened: asyncio.Future[None] = loop.create_future()  # handshake done
        self.helloed: asyncio.Future[None] = loop.create_future()
        self.done: asyncio.Future[None] = loop.create_future()

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = cast(asyncio.Transport, transport)  # uvloop's is no subclass of it
        self.transport.write(
            (
                f"GET {self.uri.resource_name} HTTP/1.1\r\n"
                f"Host: {self.uri.host}:{self.uri.port}\r\nUpgrade: websocket\r\n"
                f"Connection: Upgrade\r\nSec-WebSocket-Key: {self.key}\r\n"
                f"Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: {PROTOCOL}"
                "\r\n\r\n"
            ).encode()
        )

    def data_received(self, data: bytes) -> None:
        t = time.time()
        buf = self.buf
        buf += data
        if not self.open:
            end = buf.find(b"\r\n\r\n")
            if end < 0:
                return
            head = bytes(buf[:end]).decode("latin-1")
            accept = base64.b64encode(hashlib.sha1((self.key + _GUID).encode()).digest())
            if not head.startswith("HTTP/1.1 101") or accept.decode() not in head:
                self._fail(ConnectionError(f"handshake refused: {head.splitlines()[0]}"))
                return
            del buf[: end + 4]
            self.open = True
            self.opened.set_result(None)
        at = 0
        while len(buf) - at >= 2:
            b0, b1 = buf[at], buf[at + 1]
            if b1 & 0x80 or not b0 & 0x80:
                self._fail(ConnectionError("masked or fragmented frame from the server"))
                return
            n, start = b1 & 0x7F, at + 2
            if n == 126:
                n, start = int.from_bytes(buf[at + 2 : at + 4], "big"), at + 4
            elif n == 127:
                n, start = int.from_bytes(buf[at + 2 : at + 10], "big"), at + 10
            if len(buf) < start + n:
                break
            opcode = b0 & 0x0F
            if opcode == 0x2:  # binary
                self._message(msgpack.unpackb(buf[start : start + n]), t)
            elif opcode == 0x9:  # ping (uvicorn's keepalive): answer, or it hangs up
                self._send(0xA, bytes(buf[start : start + n]))
            elif opcode == 0x8:  # the server closed before the run ended
                self.log.errors += 1
                self.log.end_state = "closed by the server"
                self._close()
            at = start + n
        del buf[:at]

    def connection_lost(self, exc: Exception | None) -> None:
        self._fail(exc or ConnectionError("the server closed the connection"))

    def _message(self, msg: dict[str, Any], t: float) -> None:
        kind, log = msg["type"], self.log
        if kind == "frame":
            log.frame(msg["k0"], msg["n"], t)
        elif kind == "hello":
            log.run = msg["run"]
            self.helloed.set_result(None)
        elif kind == "skipped":
            log.skipped += 1
        elif kind == "error":
            log.errors += 1
        elif kind == "status" and msg["state"] in ENDED:
            log.end_state, log.end_k = msg["state"], msg["k"]
            self._close()

    def _close(self) -> None:
        """Send a masked close frame (code 1000) and hang up."""
        if self.transport is not None and not self.transport.is_closing():
            self._send(0x8, (1000).to_bytes(2, "big"))
            self.transport.close()
        if not self.done.done():
            self.done.set_result(None)

    def _send(self, opcode: int, payload: bytes) -> None:
        """A masked control frame (payload ≤ 125 bytes)."""
        assert self.transport is not None and len(payload) <= 125
        mask = os.urandom(4)
        masked = bytes(c ^ mask[i % 4] for i, c in enumerate(payload))
        self.transport.write(bytes([0x80 | opcode, 0x80 | len(payload)]) + mask + masked)

    def _fail(self, exc: BaseException) -> None:
        for fut in (self.opened, self.helloed, self.done):
            if not fut.done():
                fut.set_exception(exc)


async def watch(url: str, log: Log, helloed: asyncio.Semaphore, gate: asyncio.Semaphore) -> None:
    uri = parse_uri(url)
    async with gate:
        _, proto = await asyncio.get_running_loop().create_connection(
            lambda: Watch(url, log), uri.host, uri.port
        )
        await asyncio.wait_for(proto.opened, 120)
    await proto.helloed
    helloed.release()
    await proto.done


async def run_clients(urls: list[str], out: Path) -> None:
    logs = [Log() for _ in urls]
    helloed = asyncio.Semaphore(0)
    gate = asyncio.Semaphore(50)  # connections opening at once
    tasks = [
        asyncio.create_task(watch(u, log, helloed, gate)) for u, log in zip(urls, logs, strict=True)
    ]
    for _ in urls:
        await helloed.acquire()
    print(json.dumps({"ready": len(urls)}), flush=True)
    await asyncio.gather(*tasks)
    save(logs, out)


def save(logs: list[Log], out: Path) -> None:
    per = {
        name: np.array([getattr(log, name) for log in logs])
        for name in ("missing", "overlap", "skipped", "errors", "end_state", "end_k", "next_k")
    }
    run = {
        name: np.array([log.run[name] for log in logs])
        for name in ("id", "started_at", "Ts", "n_planned")
    }
    np.savez(
        out,
        **per,
        **{f"run_{k}": v for k, v in run.items()},
        frame_w=np.repeat(np.arange(len(logs)), [len(log.k_last) for log in logs]),
        frame_k=np.concatenate([np.frombuffer(log.k_last, np.int64) for log in logs]),
        frame_t=np.concatenate([np.frombuffer(log.t_recv, np.float64) for log in logs]),
    )


async def run_peer(port: int, clients: int, duration: float, Ts: float) -> None:
    conns: set[ServerConnection] = set()
    full = asyncio.Event()

    async def handler(conn: ServerConnection) -> None:
        conns.add(conn)
        if len(conns) >= clients:
            full.set()
        await conn.wait_closed()
        conns.discard(conn)

    # no permessage-deflate, as `elab serve`: both send the same bytes
    async with serve(
        handler,
        "127.0.0.1",
        port,
        subprotocols=[PROTOCOL],  # type: ignore[list-item]
        ping_interval=None,
        max_size=None,
        compression=None,
    ):
        print(json.dumps({"listening": port}), flush=True)
        await full.wait()
        await stream_frames(conns, duration, Ts)
        for _ in range(600):
            if not conns:
                break
            await asyncio.sleep(0.1)


async def stream_frames(conns: set[ServerConnection], duration: float, Ts: float) -> None:
    """Frame ``s`` (samples ``[sF, (s+1)F)``) is sent when its last sample is due."""
    n, F = round(duration / Ts), frame_samples(Ts)
    t0 = time.time()
    broadcast(
        conns,
        pack(
            {
                "type": "hello",
                "protocol": PROTOCOL,
                "live_seq": 0,
                "run": {
                    "id": "peer",
                    "Ts": Ts,
                    "n_planned": n,
                    "frame_samples": F,
                    "started_at": t0,
                },
            }
        ),
    )
    data = np.random.default_rng(1).standard_normal((F, len(NAMES)))
    for seq in range(math.ceil(n / F)):
        k0 = seq * F
        m = min(F, n - k0)
        await asyncio.sleep(max(0.0, t0 + (k0 + m - 1) * Ts - time.time()))
        broadcast(conns, encode_frame(NAMES, F, k0, data[:m]))
    broadcast(conns, pack({"type": "status", "state": "finished", "k": n}))


def main(argv: list[str]) -> None:
    p = argparse.ArgumentParser(prog="python -m tests.bench.wsload")
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("client", help="watch the websocket URLs read from stdin, one a line")
    c.add_argument("--out", type=Path, required=True)
    s = sub.add_parser("peer", help="plain websockets broadcast server")
    s.add_argument("--port", type=int, required=True)
    s.add_argument("--clients", type=int, required=True)
    s.add_argument("--duration", type=float, required=True)
    s.add_argument("--Ts", type=float, default=0.001)
    args = p.parse_args(argv)
    if args.cmd == "client":
        urls = [line.strip() for line in sys.stdin if line.strip()]
        uvloop.run(run_clients(urls, args.out))
    else:
        uvloop.run(run_peer(args.port, args.clients, args.duration, args.Ts))


if __name__ == "__main__":
    main(sys.argv[1:])
