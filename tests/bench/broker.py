"""Engines on a broker against the engine the server starts (issue 29): the same live
benchmark as *Live server* (``tests/bench/server.py``: real-time flexible-link runs, one
watcher each from sample 0, a steady-state window, every recording compared with the
offline simulation), once with the server's own engine process on its socket pair and once
with two ``elab engine`` processes on a Redis broker (Debian's redis-server on loopback),
interleaved, in the same benchmark run. Server CPU counts every process of the lab: the web
process, its engine(s) and, on the broker, redis-server."""

from __future__ import annotations

import time

from tests.bench.server import bench_elab
from tests.redis_server import RedisServer

ROUNDS = 2


def bench_broker(n: int = 300, seconds: float = 30.0) -> str:
    broker = RedisServer()
    broker.start()
    assert broker.proc is not None
    t = time.monotonic()
    local, remote = [], []
    try:
        for _ in range(ROUNDS):
            local.append(bench_elab(n, 1, seconds))
            remote.append(
                bench_elab(
                    n, 1, seconds, extra={"broker": broker.proc.pid}, ELAB_REDIS_URL=broker.url()
                )
            )
    finally:
        broker.stop()
    wall = time.monotonic() - t

    def cell(results: list[dict[str, float]], key: str, fmt: str) -> str:
        return " / ".join(format(r[key], fmt) for r in results)

    def row(label: str, key: str, fmt: str) -> str:
        return f"| {label} | {cell(local, key, fmt)} | {cell(remote, key, fmt)} |"

    cpu = [r["server_core"] for r in remote]
    base = [r["server_core"] for r in local]
    ratio = " / ".join(f"{a / b:.2f}×" for a, b in zip(cpu, base, strict=True))
    rec = [f"{r['rec_missing']:.0f} missing, {r['rec_differing']:.0f} differing" for r in remote]
    return f"""## Engines on a broker (issue 29)

{n} real-time flexible-link runs (Ts = 1 ms, 20 ms frames), one watcher each from sample 0,
a {seconds:.0f} s steady-state window, then every run stopped, downloaded and compared
with the offline simulation; as in *Live server*. The peer is the same lab with the engine
the server starts (socket pair); against it, the simulation engines as two `elab engine`
processes on a Redis broker (redis-server 7 on loopback, nothing saved to disk), the
records in the same SQLite file. Each cell: the {ROUNDS} rounds, interleaved.

| figure | the server's own engine (peer) | two engines on Redis |
|---|---|---|
{row("lab CPU, share of one core (all its processes)", "server_core", ".2f")}
{row("… the web process", "web_core", ".2f")}
{row("… the engine process(es)", "engine_core", ".2f")}
{row("… redis-server", "broker_core", ".2f")}
{row("latency p50 (ms)", "p50", ".1f")}
{row("latency p99 (ms)", "p99", ".1f")}
{row("latency max (ms)", "max", ".1f")}
{row("samples missing at the watchers", "watch_missing", ".0f")}
{row("watchers that missed the end of their run, or got an error", "short", ".0f")}
| recordings vs offline simulation (broker) | | {" / ".join(rec)} |
| **ratio of lab CPU, broker / own engine** | | **{ratio}** |

The whole benchmark took {wall:.0f} s.
"""
