"""The web side of engines on a broker (:class:`elab.engines.broker.BrokerEngines`) against
a real ``elab engine`` process on a real redis-server: the order the socket pair gave,
kept over the broker, and what a web process that fell behind is told."""

from __future__ import annotations

import asyncio
import json
import math
import os
import signal
import subprocess
import time
from pathlib import Path

import redis.asyncio

from elab.engines import wire
from elab.engines.base import Block, Changed, Ended, Health, RunOrder
from elab.engines.broker import BrokerEngines, _Member
from elab.plants import get_plant
from elab.runs.manager import new_run_id
from elab.sim import RunSpec, Square
from elab.store import open_store
from elab.store.base import ParamChange, RunRecord
from tests.api.server import ELAB
from tests.redis_server import RedisServer

FLEX = get_plant("flexible_link")


class Heard:
    """What the engines said, in the order this process heard it."""

    def __init__(self) -> None:
        self.said: list[tuple[str, str]] = []  # (what, run)

    def started(self, engine: str, record: RunRecord, order: object = None) -> None:
        self.said.append(("started", record.id))

    def blocks(self, engine: str, blocks: list[Block]) -> None:
        pass

    def changed(self, engine: str, change: Changed) -> None:
        self.said.append((f"changed {change.state.value}", change.run_id))

    def params(self, engine: str, run_id: str, change: ParamChange, new: object = None) -> None:
        pass

    def committed(self, engine: str, counts: dict[str, int]) -> None:
        pass

    def ended(self, engine: str, run_id: str, ended: Ended) -> None:
        self.said.append((f"ended {ended.state.value}", run_id))

    def stored(self, engine: str, run_id: str) -> None:
        self.said.append(("stored", run_id))

    def health(self, engine: str, health: Health) -> None:
        pass

    def lost(self, engine: str, reason: str) -> None:
        self.said.append(("lost", reason))

    def resync(self, engine: str) -> None:
        self.said.append(("resync", engine))


def order(duration: float) -> RunOrder:
    spec = RunSpec(FLEX, FLEX.predefined, Square(math.radians(30), 2.0), duration=duration)
    return RunOrder(new_run_id(), spec, "realtime", "simulation", "analysis", {})


async def until(cond: object, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():  # type: ignore[operator]
        assert time.monotonic() < deadline, f"not reached in {timeout} s"
        await asyncio.sleep(0.05)


def test_each_command_is_answered_after_the_events_it_caused(
    tmp_path: Path, redis_server: RedisServer
) -> None:
    url = redis_server.url()
    open_store(tmp_path / "elab.sqlite3").close()  # migrated, as the web process does
    env = {**os.environ, "ELAB_DATA": str(tmp_path), "ELAB_REDIS_URL": url}
    engine = subprocess.Popen([ELAB, "engine", "--name", "e-1"], env=env)

    async def scenario() -> list[tuple[str, str]]:
        heard = Heard()
        engines = BrokerEngines("simulation", url, command_timeout=30)
        await engines.start(heard)
        try:
            await until(lambda: engines.status().up)
            junk = redis.asyncio.Redis.from_url(url)  # registry entries nobody should trust
            await junk.hset("elab:engines", "odd", "{not json")
            await junk.hset("elab:engines", "e-2", json.dumps({"kind": "simulation", "since": "x"}))
            await junk.hset("elab:engines", "a:b", json.dumps({"kind": "simulation"}))
            await junk.aclose()
            await asyncio.sleep(1.5)  # found by the registry's next reading: read from now
            runs = [await engines.add(order(30.0)) for _ in range(5)]
            for r in runs:  # its start was heard before the answer that it started
                assert ("started", r.id) in heard.said
            for r in runs:
                await engines.control(r.id, "pause")
                assert ("changed paused", r.id) in heard.said
                await engines.control(r.id, "stop", "stopped by the test")
            await until(lambda: sum(w == "stored" for w, _ in heard.said) == 5)
            assert [s.engine for s in engines.statuses() if s.up] == ["e-1"]
            return heard.said
        finally:
            await engines.close()

    try:
        said = asyncio.run(scenario())
    finally:
        engine.send_signal(signal.SIGTERM)
        assert engine.wait(60) == 0
    ends = [run for what, run in said if what.startswith("ended")]
    assert len(ends) == 5 and all(("ended stopped", run) in said for run in ends)


def test_a_web_process_that_missed_messages_says_how_many(redis_server: RedisServer) -> None:
    async def scenario() -> None:
        heard = Heard()
        engines = BrokerEngines("simulation", redis_server.url())
        await engines.start(heard)
        try:
            member = engines._members.setdefault("e-1", _member("e-1"))
            beat = wire.event_out(wire.Beat(Health("e-1", 42, 0, {})))
            for n in (1, 2, 7):  # 3..6 trimmed away before this process read them
                engines._take(member, {b"m": beat, b"n": str(n).encode()})
            st = engines.status()
            assert st.up and st.pid == 42
            assert st.warning == "this web process missed 4 engine messages"
            assert heard.said == [("resync", "e-1")]  # its runs' ends: from the store
        finally:
            await engines.close()

    asyncio.run(scenario())


def _member(name: str) -> _Member:
    return _Member(name, "0-0")


def test_a_new_incarnation_ends_the_runs_of_the_last(redis_server: RedisServer) -> None:
    """A Ready from another process of the same engine, before the first was missed: its
    runs are lost (the new one ended them in the store as it started)."""

    async def scenario() -> list[tuple[str, str]]:
        heard = Heard()
        engines = BrokerEngines("simulation", redis_server.url())
        await engines.start(heard)
        try:
            member = engines._members.setdefault("e-1", _member("e-1"))
            frames = [
                wire.event_out(wire.Beat(Health("e-1", 42, 0, {}))),
                wire.event_out(wire.Ready("e-1", 43, ["r-1"])),
            ]
            for n, frame in enumerate(frames, 1):
                engines._take(member, {b"m": frame, b"n": str(n).encode()})
            return heard.said
        finally:
            await engines.close()

    said = asyncio.run(scenario())
    assert said == [("lost", "the engine process ended and started again")]
