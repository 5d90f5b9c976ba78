"""The two load processes of the live-server benchmark (:mod:`tests.bench.server`).

``client``: one asyncio process holding every websocket (subprotocol ``elab.v1``,
msgpack). Each watcher waits for ``hello``, then logs for every ``frame`` the
index of its last sample and the wall time (``time.time()``) it was received,
counts samples missing between frames, overlaps, ``skipped`` notices and
``error`` messages, and closes on the final ``status`` (finished, stopped, ...).
Once every watcher has its ``hello`` it prints one JSON line ``{"ready": n}``.
At the end it writes everything to an ``.npz`` file.

``peer``: a plain ``websockets`` server that sends the same messages (a
``hello``, 20-sample msgpack frames of 8 float32 channels at 50 frames/s, a
final ``status``) to every client with :func:`websockets.asyncio.server.broadcast`,
encoding each frame once. It starts once ``--clients`` clients are connected.

Run as ``python -m tests.bench.wsload client|peer ...`` from the project root.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import sys
import time
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgpack
import numpy as np
from websockets.asyncio.client import connect
from websockets.asyncio.server import ServerConnection, broadcast, serve

from elab.runs.fanout import encode_frame, frame_samples, pack

PROTOCOL = "elab.v1"
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


async def watch(url: str, log: Log, helloed: asyncio.Semaphore, gate: asyncio.Semaphore) -> None:
    async with gate:
        conn = await connect(url, subprotocols=[PROTOCOL], max_size=None,  # type: ignore[list-item]
                             ping_interval=None, open_timeout=120)
    async with conn:
        log.run = msgpack.unpackb(await conn.recv())["run"]
        helloed.release()
        async for raw in conn:
            t = time.time()
            msg = msgpack.unpackb(raw)
            kind = msg["type"]
            if kind == "frame":
                log.frame(msg["k0"], msg["n"], t)
            elif kind == "skipped":
                log.skipped += 1
            elif kind == "error":
                log.errors += 1
            elif kind == "status" and msg["state"] in ENDED:
                log.end_state, log.end_k = msg["state"], msg["k"]
                return


async def run_clients(urls: list[str], out: Path) -> None:
    logs = [Log() for _ in urls]
    helloed = asyncio.Semaphore(0)
    gate = asyncio.Semaphore(50)  # connections opening at once
    tasks = [asyncio.create_task(watch(u, log, helloed, gate)) for u, log in zip(urls, logs,
                                                                                   strict=True)]
    for _ in urls:
        await helloed.acquire()
    print(json.dumps({"ready": len(urls)}), flush=True)
    await asyncio.gather(*tasks)
    save(logs, out)


def save(logs: list[Log], out: Path) -> None:
    per = {name: np.array([getattr(log, name) for log in logs]) for name in
           ("missing", "overlap", "skipped", "errors", "end_state", "end_k", "next_k")}
    run = {name: np.array([log.run[name] for log in logs]) for name in
           ("id", "started_at", "Ts", "n_planned")}
    np.savez(out, **per, **{f"run_{k}": v for k, v in run.items()},
             frame_w=np.repeat(np.arange(len(logs)), [len(log.k_last) for log in logs]),
             frame_k=np.concatenate([np.frombuffer(log.k_last, np.int64) for log in logs]),
             frame_t=np.concatenate([np.frombuffer(log.t_recv, np.float64) for log in logs]))


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
    async with serve(handler, "127.0.0.1", port, subprotocols=[PROTOCOL],  # type: ignore[list-item]
                     ping_interval=None, max_size=None, compression=None):
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
    broadcast(conns, pack({"type": "hello", "protocol": PROTOCOL, "live_seq": 0, "run": {
        "id": "peer", "Ts": Ts, "n_planned": n, "frame_samples": F, "started_at": t0}}))
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
        asyncio.run(run_clients(urls, args.out))
    else:
        asyncio.run(run_peer(args.port, args.clients, args.duration, args.Ts))


if __name__ == "__main__":
    main(sys.argv[1:])
