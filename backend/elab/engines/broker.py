"""Engines on a broker (Redis): engine processes of their own (``elab engine``, on any host
that reaches the broker and the store) and the web process that sends them runs.

Each engine has two streams. Its **inbox**, ``elab:engine:<id>:in``, holds the commands
web processes send it (framed :mod:`elab.engines.wire` commands; a command's id is unique
to the process that sent it). Its **outbox**, ``elab:engine:<id>:out``, holds every message
it sends — events, heartbeats, replies — appended by its one sending thread in the order
they happen, so a reader of the outbox sees a command's events before its reply, as on
the socket pair of an engine the web process started (:mod:`elab.engines.process`): the
ordering the pipe gave, kept by having one writer and one stream per engine. Entries
carry a sequence number (from 1 in each incarnation) so that a reader knows when it
missed some: the outbox keeps the last :data:`KEEP` seconds.

The **registry**, the hash ``elab:engines``, says for each engine its kind, process, host,
protocol and the outbox entry its incarnation began at. A web process reads the outboxes
of the engines of a kind (:class:`BrokerEngines`, one :class:`~elab.engines.base.Engine`
for all of them): a new run goes to the one with the fewest live runs, a command on a run
to the engine stepping it; an engine whose heartbeats stop for ``stall_timeout`` s is lost
(its runs end interrupted, as with a process that died).
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import logging
import os
import re
import secrets
import signal
import socket
import threading
import time
from collections import Counter
from collections.abc import Callable, Coroutine
from dataclasses import dataclass, replace
from typing import Any, assert_never, cast

import redis
import redis.asyncio
from redis.asyncio.retry import Retry as AsyncRetry
from redis.backoff import ExponentialBackoff
from redis.retry import Retry

from elab.engines import wire
from elab.engines.base import Action, EngineEvents, EngineStatus, Health, NewParams, RunOrder
from elab.engines.process import answer, judged, sample_index
from elab.errors import Conflict, ElabError, TooMany, Unavailable
from elab.store.base import RunRecord

log = logging.getLogger(__name__)

#: the hash of the engines on the broker: id -> JSON (kind, pid, host, protocol, since, at)
REGISTRY = "elab:engines"
#: s an outbox keeps its messages (a web process that falls further behind misses some)
KEEP = 30.0
#: commands an inbox keeps (an engine reads them as they come)
INBOX = 1000
#: connections a web process opens to the broker: one reads, the rest send commands
CONNECTIONS = 8
#: s between an engine's registry writes (a broker restarted empty learns it again)
ANNOUNCE = 5.0
#: s an engine keeps trying a broker that does not answer before it gives up
PATIENCE = 30.0
_POLL = 0.5  # s a read blocks: how soon a stopping engine notices
HEARTBEAT = 0.5  # s between an engine's heartbeats (elab.engines.child.HEARTBEAT)


_PREFIX = "elab:engine:"
#: an engine's name (`elab engine --name`): a key part on the broker, an id in the store
NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,39}")


def inbox(engine: str) -> str:
    return f"{_PREFIX}{engine}:in"


def outbox(engine: str) -> str:
    return f"{_PREFIX}{engine}:out"


def redacted(url: str) -> str:
    """``url`` without its password."""
    scheme, sep, rest = url.partition("://")
    if "@" not in rest:
        return url
    return f"{scheme}{sep}…@{rest.rsplit('@', 1)[-1]}"


# -- the engine's side ---------------------------------------------------------------------
class EngineLink:
    """An engine's link to the broker (:class:`elab.engines.child.Link`): commands from its
    inbox, messages to its outbox, its entry in the registry. SIGTERM or SIGINT end it (the
    engine then interrupts its live runs, stores them and exits)."""

    def __init__(self, url: str, engine: str, kind: str) -> None:
        self.engine, self.kind = engine, kind
        self.ended = "the engine was shut down"
        self._r = _client(url)
        self._since: str | None = None  # where its outbox began, once announced
        self._announced = 0.0  # monotonic time it last wrote its registry entry
        self._last = "0-0"  # the last inbox entry read
        self._seq = itertools.count(1)
        self._stopping = threading.Event()
        self._buffer: list[bytes] = []
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, lambda *_: self._stopping.set())
        try:  # at once, not after the client's retries: its supervisor starts it again
            with redis.Redis.from_url(url, socket_connect_timeout=5.0) as first:
                self._last = _last_id(first, inbox(engine))  # older commands were not for it
        except redis.RedisError as exc:
            raise ElabError(f"the broker at {redacted(url)} does not answer: {exc}") from exc

    def send(self, message: bytes) -> None:
        fields = {"m": message, "n": next(self._seq)}
        keep = f"{int((time.time() - KEEP) * 1000)}-0"
        try:
            if self._since is not None and time.monotonic() - self._announced > ANNOUNCE:
                self._register()  # again: a broker restarted without its data forgot it
            self._r.xadd(outbox(self.engine), fields, minid=keep, approximate=True)  # type: ignore[arg-type]
        except redis.RedisError as exc:  # after the client's retries
            raise OSError(f"the broker: {exc}") from exc

    def receive(self) -> bytes | None:
        failing: float | None = None
        while not self._buffer:
            if self._stopping.is_set():
                return None
            try:
                answer = self._r.xread({inbox(self.engine): self._last}, count=64, block=500)
                failing = None
            except redis.RedisError as exc:
                failing = failing or time.monotonic()
                if time.monotonic() - failing > PATIENCE:
                    self.ended = f"the engine lost the broker for {PATIENCE:g} s: {exc}"
                    return None
                time.sleep(_POLL)
                continue
            for _, entries in _read(answer):
                for entry_id, fields in entries:
                    self._last = _text(entry_id)
                    try:
                        self._buffer.append(wire.unframe(fields[b"m"])[0])
                    except (KeyError, ValueError) as exc:
                        log.error("an inbox entry the engine cannot read: %s", exc)
        return self._buffer.pop(0)

    def announce(self) -> None:
        self._since = _last_id(self._r, outbox(self.engine))
        self._register()

    def _register(self) -> None:
        self._announced = time.monotonic()
        info = {
            "kind": self.kind,
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "protocol": wire.PROTOCOL,
            "since": self._since,
            "at": time.time(),
        }
        self._r.hset(REGISTRY, self.engine, json.dumps(info))

    def close(self) -> None:
        with contextlib.suppress(redis.RedisError):
            mine = self._r.hget(REGISTRY, self.engine)
            if mine is not None and json.loads(mine).get("pid") == os.getpid():
                self._r.hdel(REGISTRY, self.engine)
        self._r.close()


def _client(url: str) -> redis.Redis:
    # a command is tried again on a new connection for about PATIENCE s in all
    retry = Retry(ExponentialBackoff(cap=2.0, base=0.05), retries=int(PATIENCE / 2) + 5)
    return redis.Redis.from_url(
        url,
        retry=retry,
        retry_on_error=[redis.ConnectionError, redis.TimeoutError],
        socket_timeout=10.0,
        socket_connect_timeout=5.0,
    )


#: what XREAD answers: for each stream, its entries (id, fields)
Read = list[tuple[bytes, list[tuple[bytes, dict[bytes, bytes]]]]]


def _read(answer: object) -> Read:
    return cast(Read, answer or [])


def _last_id(r: redis.Redis, stream: str) -> str:
    return _newest(r.xrevrange(stream, count=1))


def _newest(entries: object) -> str:
    """The id of the first of ``entries`` (XREVRANGE's answer), or ``0-0`` if none."""
    last = cast(list[tuple[bytes, dict[bytes, bytes]]], entries)
    return _text(last[0][0]) if last else "0-0"


def _text(value: bytes | str) -> str:
    return value.decode() if isinstance(value, bytes) else value


# -- the web process's side ----------------------------------------------------------------
@dataclass
class _Member:
    """An engine on the broker as this web process knows it."""

    id: str
    read_from: str  # the outbox entry after which this process reads next
    pid: int | None = None
    seq: int = 0  # the last message's sequence number
    beat: float | None = None  # monotonic time of its last heartbeat
    health: Health | None = None
    up: bool = False
    problem: str | None = None  # why it is not taking runs (another protocol)
    missed: int = 0  # messages this process missed (it fell more than KEEP s behind)
    adding: int = 0  # new runs sent to it and not yet answered
    lost: int | None = None  # the process this web process judged lost, if it was
    closing: bool = False  # told to close (lost, yet it reported again)
    follow: bool = False  # running before this process started: to say its runs again


class BrokerEngines:
    """The engines of one kind on a broker, as one :class:`~elab.engines.base.Engine`."""

    def __init__(
        self,
        kind: str,
        url: str,
        *,
        command_timeout: float = 10.0,
        stall_timeout: float = 30.0,
    ) -> None:
        self.kind = kind
        self.id = f"{kind}@broker"
        self.url = url
        self.command_timeout = command_timeout
        self.stall_timeout = stall_timeout
        # commands wait for one of a few connections (a burst of 300 new runs opened one
        # each, past the broker's limit: "Too many connections"); a connection the broker
        # closed (it restarted) is replaced, the command sent again
        # (a command that reached the engine twice is answered twice: the first answer
        # counts, a second stop is a refusal nobody waits for)
        pool = redis.asyncio.BlockingConnectionPool.from_url(
            self.url,
            max_connections=CONNECTIONS,
            timeout=self.command_timeout,
            socket_timeout=10.0,
            socket_connect_timeout=5.0,
            retry=AsyncRetry(ExponentialBackoff(cap=1.0, base=0.05), retries=3),
            retry_on_error=[redis.ConnectionError, redis.TimeoutError],
        )
        self._r = redis.asyncio.Redis(connection_pool=pool)
        self._events: EngineEvents | None = None
        self._members: dict[str, _Member] = {}
        self._owner: dict[str, str] = {}  # live run -> the engine stepping it
        self._pending: dict[int, tuple[str, asyncio.Future[RunRecord | int | None]]] = {}
        # command ids unique to this process among all that send the engines commands
        self._ids = itertools.count(secrets.randbits(40) << 12)
        self._problem: str | None = "not started"
        self._reading: asyncio.Task[None] | None = None
        self._looked = 0.0  # monotonic time the registry was last read
        self._restarts = 0
        self._reported = asyncio.Event()  # set once an engine has been heard
        self._tasks: set[asyncio.Task[None]] = set()

    # -- lifecycle -----------------------------------------------------------------------
    async def start(self, events: EngineEvents) -> None:
        self._events = events
        try:  # what the engines said before this process started is not for it
            await self._discover(fresh=True)
            self._problem = None
        except redis.RedisError as exc:
            self._problem = f"the broker at {redacted(self.url)} does not answer: {exc}"
            log.error("%s", self._problem)
        self._reading = asyncio.get_running_loop().create_task(self._read_loop())

    async def close(self) -> None:
        """Stop listening; the engines go on (they are processes of their own)."""
        if self._reading is not None:
            self._reading.cancel()
            await asyncio.gather(self._reading, return_exceptions=True)
        for _, fut in self._pending.values():
            if not fut.done():
                fut.set_exception(Unavailable("the server is shutting down", retry_after=2.0))
        await self._r.aclose(close_connection_pool=True)

    def presence(self) -> BrokerPresence:
        """Owners' presence shared with the other web processes on this broker."""
        return BrokerPresence(self._r)

    def status(self) -> EngineStatus:
        """The engines as one: an engine up with a problem (its store failed: the store is
        one for all of them), else one with a warning, else the busiest; if none is up,
        why."""
        now = time.monotonic()
        up = [m for m in self._members.values() if m.up]
        if not up:
            problem = self._problem or (
                f"no {self.kind} engine has reported on the broker at "
                f"{redacted(self.url)} (start one: `elab engine`)"
            )
            return EngineStatus(engine=self.id, up=False, problem=problem, restarts=self._restarts)
        every = [
            judged(
                m.id,
                True,
                self._problem,
                m.health,
                None if m.beat is None else now - m.beat,
                m.pid,
                self._restarts,
            )
            for m in up
        ]
        st = max(
            every,
            key=lambda st: (
                st.problem is not None,
                st.warning is not None,
                st.health.live_runs if st.health else 0,
                st.engine,
            ),
        )
        missed = sum(m.missed for m in self._members.values())
        if missed and st.warning is None:
            st = replace(st, warning=f"this web process missed {missed} engine messages")
        return st

    def statuses(self) -> list[EngineStatus]:
        """Each engine of this kind that has reported, by id."""
        now = time.monotonic()
        return [
            judged(
                m.id,
                m.up,
                m.problem or (None if m.up else "lost: it stopped reporting"),
                m.health,
                None if m.beat is None else now - m.beat,
                m.pid,
                0,
            )
            for m in sorted(self._members.values(), key=lambda m: m.id)
            if m.beat is not None or m.problem is not None
        ]

    # -- commands ----------------------------------------------------------------------------
    async def add(self, order: RunOrder) -> RunRecord:
        """Start the run on the least busy engine; one that has no room for it (its own
        limits: code runs) passes it to the next."""
        for member in await self._choose():
            member.adding += 1
            try:
                record = await self._call(member, lambda cid: wire.Add(cid, order))
            except TooMany as exc:
                full = exc
                continue
            finally:
                member.adding -= 1
            if not isinstance(record, RunRecord):
                raise ElabError(f"the {self.kind} engine answered a new run with {record!r}")
            self._owner[record.id] = member.id
            return record
        raise full

    async def control(self, run_id: str, action: Action, reason: str | None = None) -> int:
        member = self._stepping(run_id)
        answer = await self._call(member, lambda cid: wire.Control(cid, run_id, action, reason))
        return sample_index(answer)

    async def replace(self, run_id: str, new: NewParams) -> int:
        member = self._stepping(run_id)
        return sample_index(await self._call(member, lambda cid: wire.Replace(cid, run_id, new)))

    async def _choose(self) -> list[_Member]:
        """The engines up, those with the fewest runs (live and being added) first."""
        if not self._reported.is_set():  # just started: wait for the engines' heartbeats
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._reported.wait(), self.command_timeout)
        up = [m for m in self._members.values() if m.up and m.problem is None]
        failed = next((m.health.store for m in up if m.health and _failed(m.health)), None)
        if failed is not None:  # one store for all the engines: a new run would fail too
            raise Unavailable(
                f"new runs are refused while the run store fails: {failed.error}",
                retry_after=5.0,
            )
        if not up:
            raise Unavailable(
                f"no {self.kind} engine is running ({self.status().problem})", retry_after=5.0
            )
        owned = Counter(self._owner.values())  # heard of since its last heartbeat, too

        def load(m: _Member) -> tuple[int, str]:
            return max(m.health.live_runs if m.health else 0, owned[m.id]) + m.adding, m.id

        return sorted(up, key=load)

    def _stepping(self, run_id: str) -> _Member:
        member = self._members.get(self._owner.get(run_id, ""))
        if member is None:
            raise Conflict(f"run {run_id} is not live on any engine this server knows")
        if not member.up:
            raise Unavailable(
                f"run {run_id}: its engine {member.id} is not reporting", retry_after=2.0
            )
        return member

    async def _call(
        self, member: _Member, command: Callable[[int], wire.Command]
    ) -> RunRecord | int | None:
        cid = next(self._ids)
        fut: asyncio.Future[RunRecord | int | None] = asyncio.get_running_loop().create_future()
        self._pending[cid] = (member.id, fut)
        try:
            frame = wire.command_out(command(cid))
            await self._r.xadd(inbox(member.id), {"m": frame}, maxlen=INBOX, approximate=True)
            return await asyncio.wait_for(fut, self.command_timeout)
        except redis.RedisError as exc:
            raise Unavailable(f"the broker: {exc}", retry_after=2.0) from None
        except TimeoutError:
            raise Unavailable(
                f"the {self.kind} engine {member.id} did not answer within "
                f"{self.command_timeout:g} s",
                retry_after=5.0,
            ) from None
        finally:
            self._pending.pop(cid, None)

    # -- listening ---------------------------------------------------------------------------
    async def _discover(self, fresh: bool = False) -> None:
        """Engines of this kind newly in the registry: read from where each began (or, when
        this process has just started, from now)."""
        self._looked = now = time.monotonic()
        registry = {_text(k): v for k, v in (await self._r.hgetall(REGISTRY)).items()}
        for member in list(self._members.values()):
            quiet = member.beat is None or now - member.beat > 2 * HEARTBEAT
            if member.id not in registry and quiet:  # it left (stopped in order)
                if member.up:
                    self._lose(member, f"engine {member.id} has left the broker")
                del self._members[member.id]
        for engine, raw in registry.items():
            try:
                info = json.loads(raw)
            except ValueError:
                continue
            if not isinstance(info, dict) or info.get("kind") != self.kind:
                continue
            if engine in self._members or not NAME.fullmatch(engine):
                continue
            start = str(info.get("since", "0-0"))
            if fresh or not re.fullmatch(r"\d{1,20}-\d{1,20}", start):  # from now
                start = _newest(await self._r.xrevrange(outbox(engine), count=1))
            self._members[engine] = _Member(engine, start, follow=fresh)

    async def _read_loop(self) -> None:
        while True:
            try:
                if time.monotonic() - self._looked > 1.0:
                    await self._discover()
                streams = {outbox(m.id): m.read_from for m in self._members.values()}
                if not streams:
                    await asyncio.sleep(_POLL)
                else:
                    block = int(_POLL * 1000)
                    answer = await self._r.xread(streams, count=256, block=block)  # type: ignore[arg-type]
                    for key, entries in _read(answer):
                        member = self._members[_text(key).removeprefix(_PREFIX)[: -len(":out")]]
                        for entry_id, fields in entries:
                            member.read_from = _text(entry_id)
                            self._take(member, fields)
                self._problem = None
            except asyncio.CancelledError:
                raise
            except redis.RedisError as exc:
                self._problem = f"the broker at {redacted(self.url)}: {exc}"
                log.error("%s", self._problem)
                await asyncio.sleep(1.0)
            except Exception:  # a bug in a handler must not stop the listening
                log.exception("reading the engines' messages failed")
            self._check_stalls()

    def _take(self, member: _Member, fields: dict[bytes, bytes]) -> None:
        events = self._events
        assert events is not None
        try:
            seq = int(fields[b"n"])
            ev = wire.decode_event(*wire.unframe(fields[b"m"]))
        except (KeyError, ValueError) as exc:
            log.error("engine %s sent a message not understood here: %s", member.id, exc)
            return
        if member.seq and seq > member.seq + 1:  # (a new process starts again at 1)
            member.missed += seq - member.seq - 1
            log.error(
                "missed %d messages of engine %s (this web process fell more than %g s "
                "behind, or the broker lost them): its runs' ends are read from the store",
                seq - member.seq - 1,
                member.id,
                KEEP,
            )
            events.resync(member.id)
        member.seq = seq
        match ev:
            case wire.Started():
                self._owner[ev.record.id] = member.id
            case wire.RunEnded():
                self._owner.pop(ev.run, None)
            case _:
                pass
        match wire.deliver(events, member.id, ev):
            case wire.Reply() as reply:
                answer(self._pending.get(reply.id, ("", None))[1], reply)
            case wire.Beat() as beat:
                self._beat(member, beat.health)
                events.health(member.id, beat.health)
            case wire.Ready() as ready:
                self._ready(member, ready)
            case None:
                pass
            case other:
                assert_never(other)

    def _beat(self, member: _Member, health: Health) -> None:
        member.health, member.beat = health, time.monotonic()
        if member.up and member.pid is not None and health.pid != member.pid:
            self._lose(member, f"engine {member.id} started again (its start went unseen)")
            self._restarts += 1
        member.pid = health.pid
        if member.lost == member.pid:
            self._close(member)  # lost, its runs ended: it must not step them on
        elif not member.up and member.problem is None:
            member.up = True
            self._reported.set()
            if member.follow:  # its live runs began before this process: heard again
                member.follow = False
                self._spawn(self._follow(member))

    async def _follow(self, member: _Member) -> None:
        try:
            said = await self._call(member, lambda cid: wire.Follow(cid))
            log.info("engine %s: following its %s live runs", member.id, said)
        except ElabError as exc:  # they finish in the store; their records answer
            log.error("engine %s did not say its live runs: %s", member.id, exc)

    def _ready(self, member: _Member, ready: wire.Ready) -> None:
        if ready.protocol != wire.PROTOCOL:
            member.up, member.problem = (
                False,
                (
                    f"engine {member.id} speaks protocol {ready.protocol}, this server "
                    f"{wire.PROTOCOL}: it is another version of E-Lab"
                ),
            )
            log.error("%s", member.problem)
            return
        if member.up and member.pid != ready.pid:  # it started again before it was missed
            self._lose(member, "the engine process ended and started again")
            self._restarts += 1
        member.pid, member.problem, member.closing = ready.pid, None, False
        if ready.interrupted:
            log.warning(
                "engine %s: runs interrupted by its earlier end: %s",
                member.id,
                ", ".join(ready.interrupted),
            )

    def _check_stalls(self) -> None:
        now = time.monotonic()
        for member in self._members.values():
            if member.up and member.beat is not None and now - member.beat > self.stall_timeout:
                self._lose(
                    member,
                    f"engine {member.id} sent nothing for {self.stall_timeout:g} s "
                    "(ELAB_ENGINE_STALL): stopped, killed or cut off from the broker",
                )

    def _close(self, member: _Member) -> None:
        """Tell an engine judged lost that reports again (it was stopped, or cut off) to
        close: its runs have ended interrupted here, so it must not step them on; it ends
        them, exits, and its supervisor starts it again (as a stalled engine process the
        web process started is killed)."""
        if member.closing:
            return
        member.closing = True
        log.error("engine %s reports again after it was lost: telling it to close", member.id)
        frame = wire.command_out(wire.Close(f"engine {member.id} was lost: it stopped reporting"))
        r = self._r

        async def send() -> None:
            try:
                await r.xadd(inbox(member.id), {"m": frame}, maxlen=INBOX, approximate=True)
            except redis.RedisError as exc:  # it is told again at its next heartbeat
                member.closing = False
                log.error("could not tell engine %s to close: %s", member.id, exc)

        self._spawn(send())

    def _spawn(self, coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    def _lose(self, member: _Member, reason: str) -> None:
        """Its runs are over (interrupted), its unanswered commands fail."""
        member.up, member.lost = False, member.pid
        log.error("%s", reason)
        for engine, fut in self._pending.values():
            if engine == member.id and not fut.done():
                fut.set_exception(Unavailable(reason, retry_after=2.0))
        for run, engine in list(self._owner.items()):
            if engine == member.id:
                del self._owner[run]
        assert self._events is not None
        self._events.lost(member.id, reason)


def _failed(h: Health) -> bool:
    """The engine's store has failed (not a fault being retried)."""
    return not h.store.ok and not h.store.transient


class BrokerPresence:
    """When web processes last saw each run's owner
    (:class:`~elab.runs.patrol.SharedPresence`), on the broker: the hash
    ``elab:seen:<run>`` holds each process's latest sighting (unix s), kept a day; a
    sighting goes out when it is newer than the last one sent by a second."""

    def __init__(self, r: redis.asyncio.Redis) -> None:
        self._r = r
        self._me = f"web-{secrets.token_hex(6)}"
        self._sent: dict[str, float] = {}

    async def exchange(self, seen: dict[str, float]) -> dict[str, float]:
        runs = list(seen)
        fresh = {run: at for run, at in seen.items() if at > self._sent.get(run, 0.0) + 1.0}
        try:
            async with self._r.pipeline(transaction=False) as pipe:
                for run, at in fresh.items():
                    pipe.hset(f"elab:seen:{run}", self._me, repr(at))
                    pipe.expire(f"elab:seen:{run}", 86_400)
                for run in runs:
                    pipe.hvals(f"elab:seen:{run}")
                answers = await pipe.execute()
        except redis.RedisError as exc:
            raise Unavailable(f"the broker: {exc}", retry_after=2.0) from None
        self._sent = {run: fresh.get(run, self._sent.get(run, 0.0)) for run in runs}
        got = answers[2 * len(fresh) :]
        return {run: max(map(float, vals)) for run, vals in zip(runs, got, strict=True) if vals}
