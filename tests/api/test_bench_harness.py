"""The live-server benchmark's instrument (tests/bench): its websocket client and a
small run of the benchmark itself, so `make bench` cannot silently measure nothing."""

from __future__ import annotations

import asyncio
import math
from typing import Any

import msgpack
import numpy as np
import uvloop
from websockets.asyncio.server import ServerConnection, serve

from elab.api.frames import encode_frame
from tests.api.server import free_port
from tests.bench.server import bench_elab
from tests.bench.wsload import NAMES, PROTOCOL, Log, watch


def pack(message: dict[str, Any]) -> bytes:
    return msgpack.packb(message, use_bin_type=True)  # type: ignore[no-any-return]


def test_the_client_answers_keepalive_pings_and_logs_every_frame() -> None:
    """A server pinging every 0.1 s with a 0.1 s timeout (uvicorn pings every 20 s) keeps
    the client connected for 1.5 s; every frame is logged once, none is missing."""

    async def scenario() -> Log:
        async def handler(conn: ServerConnection) -> None:
            await conn.send(
                pack(
                    {
                        "type": "hello",
                        "run": {"id": "x", "Ts": 0.001, "n_planned": 600, "started_at": 0},
                    }
                )
            )
            data = np.ones((20, len(NAMES)))
            for k0 in range(0, 600, 20):
                await asyncio.sleep(0.05)
                await conn.send(encode_frame(NAMES, 20, k0, data))
            await conn.send(pack({"type": "status", "state": "finished", "k": 600}))
            await conn.wait_closed()

        port = free_port()
        async with serve(
            handler,
            "127.0.0.1",
            port,
            subprotocols=[PROTOCOL],  # type: ignore[list-item]
            ping_interval=0.1,
            ping_timeout=0.1,
        ):
            log = Log()
            await asyncio.wait_for(
                watch(f"ws://127.0.0.1:{port}/", log, asyncio.Semaphore(0), asyncio.Semaphore(1)),
                30,
            )
            return log

    log = uvloop.run(scenario())  # the loop the benchmark's processes run on
    assert (log.end_state, log.end_k, log.next_k) == ("finished", 600, 600)
    assert (log.missing, log.overlap, log.errors) == (0, 0, 0)
    assert len(log.k_last) == 30


def test_a_short_benchmark_run_sees_every_sample() -> None:
    r = bench_elab(runs=2, watchers=2, seconds=2.0)
    assert r["watchers"] == 4 and r["msg_rate"] > 0  # frames arrived in the window
    assert (r["watch_missing"], r["short"], r["skipped"], r["errors"]) == (0, 0, 0, 0)
    assert (r["rec_missing"], r["rec_differing"], r["rec_not_stopped"]) == (0, 0, 0)
    assert r["p50"] > 0  # ms: frames arrive after their samples were due
    assert math.isfinite(r["clock_drift"]) and r["late_max"] >= r["late_p99"] >= 0
