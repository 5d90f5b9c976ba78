"""An engine in a process of its own, started and supervised by the web process.

:class:`ProcessEngine` is the :class:`~elab.engines.base.Engine` the run manager
talks to; the process (:mod:`elab.engines.child`) runs the stepping, the
recording and the run state machine, so nothing in the web process (a big
download, an upload, an identification, garbage collection, even a stopped
process) can delay a sample or lose one. They speak :mod:`elab.engines.wire`
over a socket pair; samples cross in blocks (300 runs: 19 MB/s, about 0.05 core to send
and 0.02 to read; docs/benchmarks.md, "Live server", says why not shared memory).

Supervision: a process that dies (or stops sending heartbeats for
``stall_timeout`` seconds, when it is killed) is *lost*: its live runs are over
(the run manager marks them interrupted), waiting commands fail with
:class:`~elab.errors.Unavailable`, and a new process starts after a back-off.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib
import itertools
import json
import logging
import signal
import socket
import time
from collections.abc import Callable
from dataclasses import asdict
from typing import Any, assert_never

from elab.engines import wire
from elab.engines.base import (
    Action,
    EngineEvents,
    EngineStatus,
    Health,
    NewParams,
    RunOrder,
)
from elab.engines.settings import EngineSettings, RigSettings
from elab.errors import ElabError, Unavailable
from elab.jobs import Forked, import_in_fork_server
from elab.store.base import RunRecord

log = logging.getLogger(__name__)

_BACKOFF = (0.5, 1.0, 2.0, 5.0, 10.0, 30.0)  # s before each restart after a loss
_STARTUP = 120.0  # s an engine may take to load (numpy, scipy, the compiled loop)


class ProcessEngine:
    """Starts the engine process (:func:`elab.engines.child.forked`, from the fork server
    of :mod:`elab.jobs`) and forwards commands and events."""

    def __init__(
        self,
        engine_id: str,
        database: str,
        settings: EngineSettings | RigSettings,
        *,
        nice: int = 0,
        max_queue: int = 64 << 20,
        command_timeout: float = 10.0,
        stall_timeout: float = 30.0,
    ) -> None:
        import_in_fork_server([CHILD])  # before the fork server starts
        self.id = engine_id
        self.kind = "rig" if isinstance(settings, RigSettings) else "simulation"
        self.database = database
        self.settings = settings
        self.nice = nice
        self.max_queue = max_queue
        self.command_timeout = command_timeout
        self.stall_timeout = stall_timeout
        self._events: EngineEvents | None = None
        self._proc: Forked | None = None
        self._writer: asyncio.StreamWriter | None = None
        self._ready = False
        self._closing = False
        self._problem: str | None = "not started"
        self._killed: str | None = None  # why the supervisor killed the process, if it did
        self._pending: dict[int, asyncio.Future[RunRecord | int | None]] = {}
        self._ids = itertools.count()
        self._health: Health | None = None
        self._beat: float | None = None  # monotonic time of the last heartbeat
        self._restarts = 0
        self._tasks: set[asyncio.Task[None]] = set()
        self._reading: asyncio.Task[None] | None = None
        self._first = asyncio.Event()  # set once the first start has succeeded or failed

    # -- lifecycle ---------------------------------------------------------------
    async def start(self, events: EngineEvents) -> None:
        """Start the process in the background: the web process serves at once (its
        first page does not wait for the engine's imports); a command sent before the
        engine is first up waits for it (:meth:`_call`)."""
        self._events = events
        self._problem = "starting"
        self._spawn_task(self._first_start())

    async def _first_start(self) -> None:
        try:
            await self._spawn()
        except (ElabError, OSError) as exc:
            self._problem = str(exc)
            log.error("engine %s: %s", self.id, exc)
        finally:
            self._first.set()
        await self._supervise()

    async def close(self) -> None:
        self._closing = True
        for task in list(self._tasks):
            if task is not self._reading:
                task.cancel()
        proc = self._proc
        if self._ready and self._writer is not None:
            try:
                self._writer.write(wire.command_out(wire.Close("server shut down")))
                await self._writer.drain()
            except (ConnectionError, OSError):
                pass
        if proc is not None:
            try:
                await asyncio.wait_for(asyncio.to_thread(proc.wait), 30)
            except TimeoutError:
                log.error("engine %s did not stop in 30 s; killing it", self.id)
                proc.kill()
                await asyncio.to_thread(proc.wait)
        if self._reading is not None:
            await asyncio.gather(self._reading, return_exceptions=True)

    def status(self) -> EngineStatus:
        age = None if self._beat is None else time.monotonic() - self._beat
        pid = self._proc.pid if self._proc is not None and self._ready else None
        return judged(self.id, self._ready, self._problem, self._health, age, pid, self._restarts)

    def statuses(self) -> list[EngineStatus]:
        return [self.status()]

    # -- commands ------------------------------------------------------------------
    async def add(self, order: RunOrder) -> RunRecord:
        record = await self._call(lambda cid: wire.Add(cid, order))
        if not isinstance(record, RunRecord):
            raise ElabError(f"the {self.kind} engine answered a new run with {record!r}")
        return record

    async def control(self, run_id: str, action: Action, reason: str | None = None) -> int:
        return sample_index(await self._call(lambda cid: wire.Control(cid, run_id, action, reason)))

    async def replace(self, run_id: str, new: NewParams) -> int:
        return sample_index(await self._call(lambda cid: wire.Replace(cid, run_id, new)))

    async def _call(self, command: Callable[[int], wire.Command]) -> RunRecord | int | None:
        """Send the command made for a fresh id; its answer."""
        if not self._first.is_set():  # the server has just started: wait for the engine,
            # as long as for an answer (a client is not held for the engine's whole start)
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._first.wait(), self.command_timeout)
        if not self._first.is_set():
            raise Unavailable(
                f"the {self.kind} engine is starting (the server has just started); "
                "try again in a few seconds",
                retry_after=2.0,
            )
        if not self._ready or self._writer is None:
            raise Unavailable(
                f"the {self.kind} engine is not running ({self._problem}); it "
                "restarts by itself, try again shortly",
                retry_after=2.0,
            )
        cid = next(self._ids)
        fut: asyncio.Future[RunRecord | int | None] = asyncio.get_running_loop().create_future()
        self._pending[cid] = fut
        try:
            self._writer.write(wire.command_out(command(cid)))
            return await asyncio.wait_for(self._answer(fut), self.command_timeout)
        except TimeoutError:
            raise Unavailable(
                f"the {self.kind} engine did not answer within {self.command_timeout:g} s",
                retry_after=5.0,
            ) from None
        finally:
            self._pending.pop(cid, None)

    async def _answer(self, fut: asyncio.Future[RunRecord | int | None]) -> RunRecord | int | None:
        assert self._writer is not None
        await self._writer.drain()
        return await fut

    # -- the process -----------------------------------------------------------------
    async def _spawn(self) -> None:
        parent, sock = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
        options = {**asdict(self.settings), "nice": self.nice, "max_queue": self.max_queue}
        argv = [
            "--engine",
            self.id,
            "--kind",
            self.kind,
            "--database",  # a file, or a URL (forked: its password on no command line)
            self.database,
            "--settings",
            json.dumps(options),
        ]
        # forked from the fork server, which has imported the engine's modules: a spawned
        # interpreter imported numpy, scipy, python-control and numba again, 1.8 s of CPU
        # at every start and restart (the process takes a session of its own: a Ctrl-C at
        # the terminal reaches the web process, which closes the engine in order)
        forked = Forked(_engine, (sock, argv), name=f"elab-engine-{self.id}")
        try:
            self._proc = await asyncio.to_thread(forked.start)
        finally:
            sock.close()
        reader, self._writer = await asyncio.open_unix_connection(sock=parent)
        try:
            header, _ = await asyncio.wait_for(_read(reader), _STARTUP)
        except (TimeoutError, asyncio.IncompleteReadError, ConnectionError) as exc:
            self._proc.kill()
            code = await asyncio.to_thread(self._proc.wait)
            raise ElabError(
                f"the {self.kind} engine did not start ({_ended(code)}; its "
                f"messages are in the server's log)"
            ) from exc
        try:
            ready: wire.Event | None = wire.decode_event(header, b"")
        except wire.Unreadable:
            ready = None
        if not isinstance(ready, wire.Ready) or ready.protocol != wire.PROTOCOL:
            self._proc.kill()
            said = f"protocol {ready.protocol}" if isinstance(ready, wire.Ready) else header[:200]
            raise ElabError(
                f"the {self.kind} engine said {said!r} instead of ready with protocol "
                f"{wire.PROTOCOL}: it is another version of E-Lab"
            )
        self._ready, self._problem, self._beat = True, None, time.monotonic()
        if ready.interrupted:
            log.warning(
                "engine %s: runs interrupted by its earlier end: %s",
                self.id,
                ", ".join(ready.interrupted),
            )
        self._reading = self._spawn_task(self._read_loop(reader))

    async def _read_loop(self, reader: asyncio.StreamReader) -> None:
        try:
            while True:
                header, payload = await _read(reader)
                try:
                    self._dispatch(header, payload)
                except Exception:  # a bug in a handler must not cut the engine off
                    log.exception("engine %s: handling %s failed", self.id, header[:80])
        except (asyncio.IncompleteReadError, ConnectionError, OSError):
            pass
        await self._lost()

    def _dispatch(self, head: bytes, payload: bytes) -> None:
        events = self._events
        assert events is not None
        try:
            ev = wire.decode_event(head, payload)
        except wire.Unreadable as exc:
            log.error("engine %s sent a message not understood here: %s", self.id, exc)
            return
        match wire.deliver(events, self.id, ev):
            case wire.Reply() as reply:
                answer(self._pending.get(reply.id), reply)
            case wire.Beat() as beat:
                self._health, self._beat = beat.health, time.monotonic()
                events.health(self.id, beat.health)
            case wire.Ready():
                log.error("engine %s said it was ready twice", self.id)
            case None:
                pass
            case other:
                assert_never(other)

    async def _lost(self) -> None:
        self._ready = False
        proc = self._proc
        code = None
        if proc is not None:
            try:
                code = await asyncio.wait_for(asyncio.to_thread(proc.wait), 5)
            except TimeoutError:  # it closed its socket but lives on: make sure
                proc.kill()
                code = await asyncio.to_thread(proc.wait)
        reason = f"the engine process ended ({_ended(code)})"
        if self._killed is not None:
            reason = f"the engine process was killed: {self._killed}"
            self._killed = None
        self._problem = None if self._closing else reason
        for fut in self._pending.values():
            if not fut.done():
                fut.set_exception(Unavailable(reason, retry_after=2.0))
        if not self._closing:
            log.error("engine %s: %s", self.id, reason)
            assert self._events is not None
            self._events.lost(self.id, reason)

    async def _supervise(self) -> None:
        """Kill a stalled process; start a new one after a loss."""
        failures = 0
        while not self._closing:
            await asyncio.sleep(1.0)
            proc, beat = self._proc, self._beat
            if self._ready and beat is not None and proc is not None:
                if time.monotonic() - beat > self.stall_timeout:
                    self._killed = (
                        f"it sent nothing for {self.stall_timeout:g} s (ELAB_ENGINE_STALL), "
                        "so it was stalled: stopped, hung or starved of CPU"
                    )
                    log.error("engine %s: %s; killing it", self.id, self._killed)
                    proc.kill()
                continue
            if self._ready or (self._reading is not None and not self._reading.done()):
                continue
            await asyncio.sleep(_BACKOFF[min(failures, len(_BACKOFF) - 1)])
            try:
                await self._spawn()
                self._restarts += 1
                failures = 0
            except (ElabError, OSError) as exc:
                failures += 1
                self._problem = str(exc)
                log.error("engine %s: %s", self.id, exc)

    def _spawn_task(self, coro: Any) -> asyncio.Task[None]:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task


def answer(fut: asyncio.Future[RunRecord | int | None] | None, reply: wire.Reply) -> None:
    """The command waiting on ``fut`` (if it still does) gets ``reply``'s answer or error."""
    if fut is None or fut.done():
        return
    if reply.error is not None:
        fut.set_exception(reply.error)
    else:
        fut.set_result(reply.ok)


def judged(
    engine: str,
    up: bool,
    problem: str | None,
    h: Health | None,
    age: float | None,
    pid: int | None,
    restarts: int,
) -> EngineStatus:
    """An engine's status from what its link knows (``problem``: why it is not up) and what
    it last said of itself (``h``, ``age`` s ago): silent for 2 s, a stepping thread that
    does not tick or a failed store are problems; a store being retried a warning."""
    warning = None
    if problem is None and age is not None and age > 2.0:
        problem = f"the engine has not reported for {age:.1f} s"
    if problem is None and h is not None:
        if not h.stepping:
            problem = "the engine's stepping thread is not ticking"
        elif not h.store.ok and not h.store.transient:
            problem = f"the run store has failed: {h.store.error}"
        elif not h.store.ok:
            warning = f"the run store is busy, retrying: {h.store.error}"
    return EngineStatus(
        engine=engine,
        up=up,
        problem=problem,
        warning=warning,
        pid=pid,
        restarts=restarts,
        heartbeat_age=age,
        health=h,
    )


async def _read(reader: asyncio.StreamReader) -> tuple[bytes, bytes]:
    head, size = wire.lengths(await reader.readexactly(wire.HEADER_BYTES))
    header = await reader.readexactly(head)
    payload = await reader.readexactly(size) if size else b""
    return header, payload


def sample_index(answer: RunRecord | int | None) -> int:
    if not isinstance(answer, int):
        raise ElabError(f"an engine answered a command with {answer!r}, not a sample index")
    return answer


def _ended(code: int | None) -> str:
    if code is None:
        return "still running"
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = str(-code)
        return f"killed by {name}"
    return f"exit status {code}"


#: the engine process's module: named, not imported, here (it brings the stepping code,
#: numba and python-control, which the fork server imports once and the web process never)
CHILD = "elab.engines.child"


def _engine(sock: socket.socket, argv: list[str]) -> None:
    """The engine process's body, in a fork of the fork server (which imported ``CHILD``)."""
    importlib.import_module(CHILD).forked(sock, argv)
