"""The engine process: ``python -m elab.engines.child --fd N --engine ID --database PATH``,
or, as the web process starts it, :func:`forked` from its fork server; or, on a broker,
``elab engine`` (``--redis URL`` here: :mod:`elab.engines.broker`).

It runs a :class:`~elab.engines.simulation.SimulationEngine` and speaks
:mod:`elab.engines.wire` over the socket ``N`` it inherits from the web process (or its
two streams on the broker): commands in; events, heartbeats and replies out, all through
one queue, in the order they happen (an event is always out before the reply to the
command that caused it). A dedicated thread sends, so a web process that stops reading
never delays a sample: sample blocks beyond ``max_queue`` bytes are dropped (the store
has them; the web side reads the gap back), nothing else is.

When the web process goes away (end of file on the socket) or asks it to close, or an
engine on a broker is told to stop (SIGTERM, SIGINT), it interrupts its live runs,
stores everything and exits.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import json
import logging
import os
import socket
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Protocol, assert_never

from elab.engines import wire
from elab.engines.base import (
    Block,
    Changed,
    Ended,
    EngineEvents,
    Health,
    NewParams,
    RunOrder,
    SteppingEngine,
)
from elab.engines.rig import RigEngine
from elab.engines.settings import EngineSettings, RigSettings
from elab.engines.simulation import SimulationEngine
from elab.errors import ElabError
from elab.rig.driver import TcpDriver
from elab.runtime import return_memory
from elab.store import Store, open_store
from elab.store.base import ParamChange, RunRecord

log = logging.getLogger("elab.engine")

HEARTBEAT = 0.5  # s


class Outbox:
    """Messages to the web process, sent in order by a thread of their own."""

    def __init__(self, send: Callable[[bytes], None], max_bytes: int, backlog_bytes: int) -> None:
        self._sendall = send  # raises OSError once nobody can be told
        self.max_bytes = max_bytes
        self.backlog_bytes = backlog_bytes
        self._items: deque[tuple[bytes | Callable[[], bytes], int]] = deque()
        self._bytes = 0
        self._cond = threading.Condition()
        self._closing = False
        self.dropped = 0  # sample messages dropped while the web process did not read
        self.gone = False  # sending failed for good
        self._thread = threading.Thread(target=self._send, name="elab-engine-out", daemon=True)
        self._thread.start()

    def put(
        self, message: bytes | Callable[[], bytes], size: int = 0, droppable: bool = False
    ) -> None:
        """Queue ``message``, or a function that makes it (called in the sending thread, so
        the stepping thread does not encode; ``size``: about how long it will be)."""
        size = len(message) if isinstance(message, bytes) else size
        with self._cond:
            if droppable and self._bytes + size > self.max_bytes:
                self.dropped += 1
                return
            self._items.append((message, size))
            self._bytes += size
            self._cond.notify()

    def backlogged(self) -> bool:
        """More queued than a fast run should add to."""
        return self._bytes > self.backlog_bytes

    def close(self, timeout: float = 10.0) -> None:
        """Send what is queued (for at most ``timeout`` seconds), then stop."""
        with self._cond:
            self._closing = True
            self._cond.notify()
        self._thread.join(timeout)

    def _send(self) -> None:
        while True:
            with self._cond:
                while not self._items and not self._closing:
                    self._cond.wait()
                if not self._items:
                    return
                message, size = self._items.popleft()
            try:
                self._sendall(message if isinstance(message, bytes) else message())
            except OSError:  # the web process (the broker) is gone: nobody to tell
                self.gone = True
                return
            with self._cond:
                self._bytes -= size


class WireEvents:
    """:class:`~elab.engines.base.EngineEvents` that go out through an :class:`Outbox`."""

    def __init__(self, outbox: Outbox) -> None:
        self._out = outbox

    def started(self, engine: str, record: RunRecord, order: RunOrder | None = None) -> None:
        self._out.put(wire.event_out(wire.Started(record, order)))

    def blocks(self, engine: str, blocks: list[Block]) -> None:
        size = sum(b.data.nbytes for b in blocks)
        self._out.put(lambda: wire.event_out(wire.Blocks(blocks)), size, droppable=True)

    def changed(self, engine: str, change: Changed) -> None:
        self._out.put(wire.event_out(wire.StateChanged(change)))

    def params(
        self, engine: str, run_id: str, change: ParamChange, new: NewParams | None = None
    ) -> None:
        self._out.put(wire.event_out(wire.Params(run_id, change, new)))

    def committed(self, engine: str, counts: dict[str, int]) -> None:
        self._out.put(wire.event_out(wire.Committed(counts)))

    def ended(self, engine: str, run_id: str, ended: Ended) -> None:
        self._out.put(wire.event_out(wire.RunEnded(run_id, ended)))

    def stored(self, engine: str, run_id: str) -> None:
        self._out.put(wire.event_out(wire.Stored(run_id)))

    def health(self, engine: str, health: Health) -> None:
        self._out.put(wire.event_out(wire.Beat(health)))

    def lost(self, engine: str, reason: str) -> None:  # the web side's to say
        raise NotImplementedError

    def resync(self, engine: str) -> None:  # the web side's to do
        raise NotImplementedError


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    logging.basicConfig(
        stream=sys.stderr,
        level=logging.WARNING,
        format="%(asctime)s elab engine %(process)d: %(levelname)s %(message)s",
    )
    return_memory()
    options = json.loads(args.settings)
    max_queue = int(options.pop("max_queue", 64 << 20))
    nice = int(options.pop("nice", 0))
    settings: EngineSettings | RigSettings = (
        RigSettings(**options) if args.kind == "rig" else EngineSettings(**options)
    )
    _prioritise(settings.realtime, nice)  # before any thread starts: they inherit it
    if isinstance(settings, RigSettings) and settings.realtime > 0:
        _lock_memory()  # the host loop never waits for a page fault
    # a thread running Python (compiling a new run, sorting samples for the store) gives
    # the GIL to the stepping thread within 1 ms of its asking, not the default 5 ms
    sys.setswitchinterval(0.001)
    link = _link(args)
    outbox = Outbox(link.send, max_queue, backlog_bytes=min(4 << 20, max_queue // 4))
    store = open_store(args.database, migrate=False)
    store.claim(args.engine)  # before it marks "its" live runs interrupted
    engine = _build(args.kind, args.engine, store, WireEvents(outbox), settings, outbox)
    interrupted = engine.start()
    # what is loaded by now (numpy, scipy, control, numba, the compiled loop: ~160,000
    # objects) is never garbage: out of the collector's way, so that a full collection
    # does not hold the GIL for tens of milliseconds against the stepping thread (one did,
    # 5-10 s after 300 runs were started: a tick 64-110 ms late)
    gc.collect()
    gc.freeze()
    link.announce()  # on a broker: where its messages begin, for the web nodes to read
    outbox.put(wire.event_out(wire.Ready(engine.id, os.getpid(), interrupted, kind=args.kind)))
    beat = threading.Thread(
        target=_heartbeat, args=(engine, outbox), name="elab-engine-beat", daemon=True
    )
    beat.start()
    workers = ThreadPoolExecutor(2, thread_name_prefix="elab-engine-cmd")
    try:
        reason = _serve(link.receive, engine, outbox, workers) or link.ended
    finally:
        workers.shutdown(wait=True)
        engine.close(reason)
        outbox.close()
        link.close()
        store.close()
    return 0


class Link(Protocol):
    """How the engine hears commands and sends its messages: the socket to the web process
    that started it, or its streams on a broker (:class:`elab.engines.broker.EngineLink`)."""

    #: why the engine ends when :meth:`receive` says there is nothing more
    ended: str

    def send(self, message: bytes) -> None:
        """Send one framed message; :class:`OSError` once nobody can be told."""

    def receive(self) -> bytes | None:
        """The next command's header, or ``None`` at the end."""

    def announce(self) -> None:
        """The engine is about to say it is ready."""

    def close(self) -> None:
        """After the last message has been sent."""


class SocketLink:
    """The socket pair to the web process that started the engine."""

    ended = "the web server process ended"

    def __init__(self, fd: int) -> None:
        self._sock = socket.socket(fileno=fd)

    def send(self, message: bytes) -> None:
        self._sock.sendall(message)

    def receive(self) -> bytes | None:
        return _receive(self._sock)

    def announce(self) -> None:
        pass

    def close(self) -> None:
        self._sock.close()


def _link(args: argparse.Namespace) -> Link:
    if args.redis is None:
        return SocketLink(args.fd)
    from elab.engines.broker import EngineLink

    return EngineLink(args.redis, args.engine, args.kind)


def forked(sock: socket.socket, argv: Sequence[str]) -> None:
    """:func:`main` in a process forked from the web process's fork server
    (:class:`elab.jobs.Forked`; the engine's modules already imported), on the socket it was
    handed: in a session of its own first, as ``python -m elab.engines.child`` is started,
    so that a Ctrl-C at the terminal reaches only the web process, which closes the engine
    in order."""
    os.setsid()
    raise SystemExit(main([*argv, "--fd", str(sock.detach())]))


def _build(
    kind: str,
    engine_id: str,
    store: Store,
    events: EngineEvents,
    settings: EngineSettings | RigSettings,
    outbox: Outbox,
) -> SteppingEngine:
    """The engine of ``kind`` (``--kind``) with its settings."""
    match settings:
        case EngineSettings():
            return SimulationEngine(engine_id, store, events, settings, backlog=outbox.backlogged)
        case RigSettings():
            host, _, port = settings.address.rpartition(":")
            return RigEngine(engine_id, store, events, settings, lambda: TcpDriver(host, int(port)))
        case _:
            assert_never(settings)


def _serve(
    receive: Callable[[], bytes | None],
    engine: SteppingEngine,
    outbox: Outbox,
    workers: ThreadPoolExecutor,
) -> str | None:
    """Commands until the web process closes us (its reason) or goes away (``None``)."""
    while True:
        message = receive()
        if message is None:
            return None
        try:
            cmd = wire.decode_command(message)
        except wire.Unreadable as exc:
            error = ElabError(f"a command the engine cannot read: {exc}")
            outbox.put(wire.event_out(wire.Reply(exc.command_id, error=error)))
            continue
        match cmd:
            case wire.Close():
                return cmd.reason
            case wire.Add():
                _reply_when(workers.submit(engine.add, cmd.order), outbox, cmd.id)
            case wire.Control():
                _reply_when(engine.control(cmd.run, cmd.action, cmd.reason), outbox, cmd.id)
            case wire.Replace():
                _reply_when(workers.submit(engine.replace, cmd.run, cmd.new), outbox, cmd.id)
            case wire.Follow():
                _reply_when(workers.submit(engine.follow), outbox, cmd.id)
            case _:
                assert_never(cmd)


def _reply_when(fut: Future[RunRecord] | Future[int], outbox: Outbox, cid: int) -> None:
    def reply(f: Future[RunRecord] | Future[int]) -> None:
        exc = f.exception()
        if exc is None:
            outbox.put(wire.event_out(wire.Reply(cid, ok=f.result())))
            return
        if not isinstance(exc, ElabError):
            log.error("engine command failed", exc_info=exc)
            exc = ElabError(f"internal error in the engine: {exc!r}")
        outbox.put(wire.event_out(wire.Reply(cid, error=exc)))

    fut.add_done_callback(reply)


def _receive(sock: socket.socket) -> bytes | None:
    """A command's header (commands carry no payload), or ``None`` at the end."""
    prefix = _exactly(sock, wire.HEADER_BYTES)
    if prefix is None:
        return None
    head, payload = wire.lengths(prefix)
    header = _exactly(sock, head)
    if header is None or (payload and _exactly(sock, payload) is None):
        return None
    return header


def _exactly(sock: socket.socket, n: int) -> bytes | None:
    """``n`` bytes, or ``None`` once the web process has gone (closed, or killed: reset)."""
    buf = bytearray()
    while len(buf) < n:
        try:
            part = sock.recv(n - len(buf))
        except ConnectionResetError:
            return None
        if not part:
            return None
        buf += part
    return bytes(buf)


def _heartbeat(engine: SteppingEngine, outbox: Outbox) -> None:
    while True:
        time.sleep(HEARTBEAT)
        try:
            outbox.put(wire.event_out(wire.Beat(engine.health())))
        except Exception:  # reported by the missing heartbeats; the log says why
            log.exception("heartbeat failed")


def _prioritise(realtime: int, nice: int) -> None:
    """Run ahead of the web process and the identification workers. ``realtime`` > 0: the
    whole process under SCHED_FIFO one step below ``realtime`` (the stepping thread
    raises itself to ``realtime``): a thread of the engine that holds its GIL is never
    kept waiting by an ordinary process while the stepping thread waits for the GIL (with
    only the stepping thread real-time, ticks under load came up to 44 ms late, against
    5 ms; docs/benchmarks.md). The engine needs a third of a core at 300 runs and sleeps
    between ticks. Needs CAP_SYS_NICE; otherwise, or with ``realtime`` 0, the nice value
    ``nice`` where allowed; else as it is, which the server status shows as late ticks."""
    if realtime > 1:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(realtime - 1))
            return
        except (OSError, AttributeError) as exc:
            log.warning("real-time scheduling of the engine refused: %s", exc)
    if nice:
        try:
            os.setpriority(os.PRIO_PROCESS, 0, nice)
        except OSError as exc:
            log.warning("could not set the engine's priority to nice %d: %s", nice, exc)


def _lock_memory() -> None:
    """``mlockall(MCL_CURRENT | MCL_FUTURE)`` where allowed (root or CAP_IPC_LOCK): every
    page of the rig engine stays in memory; else a warning, and it runs unlocked."""
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.mlockall(3) != 0:
        log.warning(
            "mlockall refused (%s): the rig loop may wait for paging",
            os.strerror(ctypes.get_errno()),
        )


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m elab.engines.child")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--fd", type=int, help="the socket to the web process")
    where.add_argument("--redis", help="the broker's URL (an engine of its own: `elab engine`)")
    p.add_argument("--engine", required=True, help="this engine's id (its runs in the store)")
    p.add_argument("--kind", default="simulation", choices=["simulation", "rig"])
    p.add_argument("--database", required=True, help="the store: a SQLite file or a URL")
    p.add_argument("--settings", default="{}", help="EngineSettings as JSON, plus nice, max_queue")
    return p


if __name__ == "__main__":
    sys.exit(main())
