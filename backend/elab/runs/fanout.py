"""Fan-out of a run's samples to any number of watchers, as aligned frames.

Frame ``seq`` holds samples ``[seq F, (seq+1) F)`` (``F`` ≈ 20 ms of samples),
so "resume from sequence s" is sample ``s F``. A message carries one or more
whole frames (the last frame of a run may be short).

Each watcher is in one of two modes:

- **push** (default): frames are queued for it as they are published; when its
  queue holds ``max_frames`` it skips frames and is told so (``skipped``) when it
  catches up, and the run and the other watchers never wait for it;
- **pull** (after ``resume_from``): it reads from the recording at its own
  pace, while the frames published meanwhile queue as in push mode; the pull
  stops where the first queued frame begins and the watcher goes back to push
  — so every missing sample arrives, each once. (Reading on until the live
  edge instead never ends on a busy server: the edge moves during every read.)

Who sends: the server's one :class:`Sender` writes every watcher's new
messages in one pass, as ``websockets.broadcast()`` does, without waking a task
per watcher; a watcher whose connection made a send wait, or which catches up
from the recording, is served by its own task until its queue is empty.

Everything here runs on the event loop thread. Messages are encoded by a
:class:`Codec` (the wire protocol is the API layer's: :mod:`elab.api.frames`).
"""

from __future__ import annotations

import asyncio
from collections import deque
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from elab.store.base import JsonObject

Array = NDArray[np.float64]
Reader = Callable[[int, int], Awaitable[Array]]
FRAME_SECONDS = 0.02
PULL_FRAMES = 50  # frames per message while catching up from the recording
MAX_CONTROLS = 256  # answers and notices that may wait for one watcher


def frame_samples(Ts: float) -> int:
    """Samples per frame: about 20 ms of the run (at least one sample)."""
    return max(1, round(FRAME_SECONDS / Ts))


class Codec(Protocol):
    """The stream's messages as bytes."""

    def frames(
        self, names: tuple[str, ...], F: int, k0: NDArray[np.int64], data: Array
    ) -> list[bytes]:
        """``frame`` messages of R runs at once: samples ``k0[i] ..`` of run ``i`` are
        ``data[i]`` (R × n × channels, columns in the order of ``names``)."""

    def skipped(self, from_seq: int, to_seq: int) -> bytes: ...

    def status(self, state: str, k: int, error: str | None) -> bytes: ...

    def params(self, k: int, t: float, params: JsonObject) -> bytes: ...


@dataclass(eq=False)  # identity: watchers live in sets
class Watcher:
    """One subscriber: a send function, its queue of pending messages, and who sends them.

    ``direct``: the :class:`Sender` sends its messages in its pass over all watchers;
    otherwise (a send to it had to wait, or it catches up from the recording) its own
    task (:meth:`RunChannel.serve`) does, and hands it back once its queue is empty.
    """

    send: Callable[[bytes], Awaitable[None]]
    codec: Codec
    max_frames: int = 100
    # writes a message at once if the connection takes it now (True), else does nothing
    # (False: ``send`` then waits for room); None: every message goes through ``send``
    write: Callable[[bytes], bool] | None = None
    who: str = ""  # the identity watching (elab.access): its run's owner is there
    # (first sample of a frame, or None for a control message, payload)
    items: deque[tuple[int | None, bytes]] = field(default_factory=deque)
    frames_queued: int = 0
    controls_queued: int = 0  # answers and notices waiting (bounded: see control())
    skipped: tuple[int, int] | None = None  # first and last seq not delivered
    pull_from: int | None = None  # next sample to read from the recording
    closed: bool = False
    direct: bool = True
    sending: bool = False  # a send to it is under way (one at a time)
    # the own task's wake-up while it waits (a bare future: an asyncio.Event cost twice
    # as much per wake-up)
    _waiter: asyncio.Future[None] | None = field(default=None, init=False, repr=False)

    def offer(self, payload: bytes, k0: int, seq: int, frames: int) -> None:
        if self.pull_from is not None:  # catching up: queue, and let the pull fill any gap
            if self.frames_queued >= self.max_frames:
                self.drop_frames()
            self.items.append((k0, payload))
            self.frames_queued += 1
            return
        if self.frames_queued >= self.max_frames:
            first = self.skipped[0] if self.skipped else seq
            self.skipped = (first, seq + frames - 1)
            return
        self.items.append((k0, payload))
        self.frames_queued += 1

    def control(self, payload: bytes) -> None:
        self.items.append((None, payload))
        self.controls_queued += 1

    @property
    def overrun(self) -> bool:
        """More answers wait than a reading client ever lets pile up: it sends but does
        not read (issue 24: 3 M bad messages grew the server by 440 MB)."""
        return self.controls_queued > MAX_CONTROLS

    def close(self) -> None:
        self.closed = True
        self.wake()

    @property
    def has_next(self) -> bool:
        return bool(self.skipped or self.items)

    def _next(self) -> bytes:
        """The next message: a notice of skipped frames if any, else the oldest queued."""
        return self.codec.skipped(*self.skipped) if self.skipped else self.items[0][1]

    def _sent(self) -> None:
        """The message :meth:`_next` gave is on its way: take it off."""
        if self.skipped is not None:
            self.skipped = None
        else:
            k0, _ = self.items.popleft()
            self.frames_queued -= k0 is not None
            self.controls_queued -= k0 is None

    async def send_next(self) -> None:
        """Send the next message (waiting for room if the connection has none)."""
        payload = self._next()
        self._sent()
        self.sending = True
        try:
            await self.send(payload)
        finally:
            self.sending = False

    def write_next(self) -> bool:
        """Like :meth:`send_next`, without waiting: ``False`` (and nothing sent) when the
        connection has no room now or the watcher has no ``write``."""
        if self.write is None or not self.write(self._next()):
            return False
        self._sent()
        return True

    def wake(self) -> None:
        """Let its own task look again (if it waits; otherwise it has not yet looked)."""
        waiter, self._waiter = self._waiter, None
        if waiter is not None and not waiter.done():
            waiter.set_result(None)

    async def wait(self) -> None:
        """Until :meth:`wake`; the task checks its queue, mode and ``closed`` before."""
        self._waiter = asyncio.get_running_loop().create_future()
        await self._waiter

    def drop_frames(self) -> None:
        """Forget the queued frames (the control messages stay)."""
        self.items = deque(item for item in self.items if item[0] is None)
        self.frames_queued = 0

    def first_queued(self) -> int | None:
        """The first sample of the oldest queued frame."""
        return next((k0 for k0, _ in self.items if k0 is not None), None)


class _Pass:
    """One pass of the :class:`Sender` over the watchers with new messages."""

    def __init__(self, batch: list[Watcher]) -> None:
        self.batch = batch
        self.at = 0  # the watcher being sent to
        self.stuck = False  # a send waited: another pass took over the rest


class Sender:
    """Sends the direct watchers' messages in passes, one watcher after another.

    A send that completes at once (the usual case: the connection's buffer has room)
    costs no task switch, and a watcher with a direct ``write`` (the server's own
    websocket connection, past the ASGI layers: api/stream.py) costs no coroutine
    either. (Through uvicorn at 300 connections, one task per watcher
    woken per frame cost 45 µs a message, sequential sends 29 µs; docs/benchmarks.md.)
    If a send waits (a watcher that stopped reading filled its connection), the pass
    stays with that watcher until the send completes, then hands it to its own task,
    and a new pass goes on with the others at once, so it never delays them: Python
    3.12's eager task, by hand. Nothing is cancelled, so the ASGI server's ``send`` may
    wait before or after it writes.
    """

    def __init__(self) -> None:
        self._ready: list[Watcher] = []
        self._running = False  # a pass is scheduled or under way, and not stuck
        self._tasks: set[asyncio.Task[None]] = set()

    def ready(self, w: Watcher) -> None:
        """``w`` has messages: send them in the next pass, or wake its own task."""
        if not w.direct or w.pull_from is not None:
            w.wake()
            return
        self._ready.append(w)
        if not self._running:
            self._running = True
            self._start([])

    def _start(self, batch: list[Watcher]) -> None:
        task = asyncio.get_running_loop().create_task(self._run(_Pass(batch)))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _run(self, p: _Pass) -> None:
        p.batch += self._ready
        self._ready = []
        # runs at the next pass of the event loop: only if this task waits before
        watch = asyncio.get_running_loop().call_soon(self._stuck, p)
        try:
            for at, w in enumerate(p.batch):
                p.at = at
                if w.sending or not w.direct:  # another sender has it
                    continue
                try:
                    while (
                        w.direct
                        and w.pull_from is None
                        and not w.closed
                        and w.has_next
                        and not p.stuck
                    ):
                        if not w.write_next():  # no room now (or no direct write)
                            await w.send_next()
                except (OSError, RuntimeError):  # the connection broke (or closed): its
                    w.close()  # stream handler ends
                if p.stuck:  # this send waited; a new pass went on with the others
                    w.direct = False
                    w.wake()
                    return
        finally:
            watch.cancel()
            if not p.stuck:
                self._running = False

    def _stuck(self, p: _Pass) -> None:
        p.stuck = True
        self._start(p.batch[p.at + 1 :])


class RunChannel:
    """The watchers of one run and the framing of its samples."""

    def __init__(
        self,
        names: tuple[str, ...],
        Ts: float,
        read: Reader,
        codec: Codec,
        *,
        edge: int = 0,
        ended: bool = False,
        sender: Sender | None = None,
    ) -> None:
        self.names = names
        self.codec = codec
        self.sender = sender or Sender()
        self.Ts = Ts
        self.F = frame_samples(Ts)
        self.read = read
        self.edge = edge  # samples published as whole frames (or all, once ended)
        self.ended = ended
        self.watchers: set[Watcher] = set()
        self._pending: list[Array] = []
        self._pending_n = 0
        self._moved: asyncio.Event | None = None  # set when the edge moves

    def publish(self, data: Array) -> None:
        """The next samples (following those published before); whole frames go out now."""
        self._pending.append(data)
        self._pending_n += data.shape[0]
        whole = (self._pending_n // self.F) * self.F
        if whole:
            self._emit(whole)

    def end(self, status: bytes) -> None:
        """The run is over: flush the last partial frame, then the final status."""
        if self._pending_n:
            self._emit(self._pending_n)
        self.ended = True
        self.control(status)

    def control(self, payload: bytes) -> None:
        """A message for every watcher (after what is queued for each)."""
        for w in self.watchers:
            self.tell(w, payload)
        self._poke()

    def tell(self, w: Watcher, payload: bytes) -> None:
        """A message for one watcher (an answer to it), sent even when no frame follows."""
        w.control(payload)
        self.sender.ready(w)

    def _emit(self, n: int) -> None:
        data = np.concatenate(self._pending) if len(self._pending) > 1 else self._pending[0]
        out, rest = data[:n], data[n:]
        self._pending = [rest] if rest.shape[0] else []
        self._pending_n = rest.shape[0]
        self._deliver(self._frame(self.edge, out), n)

    def _deliver(self, payload: bytes, n: int) -> None:
        """Offer the message of the next ``n`` samples to every watcher."""
        k0 = self.edge
        seq, frames = k0 // self.F, -(-n // self.F)
        self.edge += n
        ready = self.sender.ready
        for w in self.watchers:
            w.offer(payload, k0, seq, frames)
            ready(w)
        self._poke()

    def _frame(self, k0: int, data: Array) -> bytes:
        return self.codec.frames(self.names, self.F, np.array([k0]), data[np.newaxis])[0]

    def lag(self, w: Watcher) -> float:
        """How far ``w`` is behind this run's stream (s): the samples published that it
        has not been sent, from its oldest queued frame or from where its catching-up from
        the recording stands (frames skipped for a slow watcher are not counted: it was
        told of them)."""
        oldest = w.pull_from if w.pull_from is not None else w.first_queued()
        return 0.0 if oldest is None else max(0, self.edge - oldest) * self.Ts

    def moved(self) -> None:
        """More of the recording can be read (pulls waiting for it look again)."""
        self._poke()

    def _poke(self) -> None:
        if self._moved is not None:
            self._moved.set()
            self._moved = None

    def resume_from(self, w: Watcher, seq: int) -> None:
        """Serve ``w`` every sample from frame ``seq`` on, from the recording."""
        w.drop_frames()
        w.skipped = None
        w.pull_from = min(max(0, seq) * self.F, self.edge)
        w.direct = False
        w.wake()

    async def serve(self, w: Watcher) -> None:
        """The watcher's own task, until it closes: sends when it is not direct."""
        while not w.closed:
            if w.sending:  # a pass still sends to it, and wakes this task when done
                await w.wait()
            elif w.pull_from is not None:
                await self._pull(w)
            elif not w.direct and w.has_next:
                await w.send_next()
            else:
                w.direct = True  # nothing left: the sender's passes take over again
                await w.wait()

    async def _pull(self, w: Watcher) -> None:
        assert w.pull_from is not None
        queued = w.first_queued()
        until = self.edge if queued is None else queued
        if w.pull_from >= until:
            w.pull_from = None  # caught up: the queued live frames follow
            w.direct = False  # sent by this task, then the sender takes over
            return
        k1 = min(until, w.pull_from + PULL_FRAMES * self.F)
        data = await self.read(w.pull_from, k1)
        if data.shape[0] == 0:  # not yet readable: wait for the recording to move
            if self._moved is None:
                self._moved = asyncio.Event()
            await self._moved.wait()
            return
        await w.send(self._frame(w.pull_from, data))
        w.pull_from += data.shape[0]


def publish_block(channels: Sequence[RunChannel | None], data: Array) -> None:
    """:meth:`RunChannel.publish` of ``data[i]`` on ``channels[i]`` (``None``: skipped)
    for the runs of a block (``data``: runs × n × channels). Runs whose new samples are
    whole frames at their channel's edge (the usual real-time case: one frame per tick)
    get their messages encoded together, one :meth:`Codec.frames` call per layout."""
    n = data.shape[1]
    together: dict[tuple[tuple[str, ...], int], list[tuple[int, RunChannel]]] = {}
    for i, ch in enumerate(channels):
        if ch is None:
            continue
        if ch._pending_n == 0 and n and n % ch.F == 0:
            together.setdefault((ch.names, ch.F), []).append((i, ch))
        else:
            ch.publish(data[i])
    for (names, F), runs in together.items():
        rows = data if len(runs) == data.shape[0] else data[[i for i, _ in runs]]
        k0 = np.array([ch.edge for _, ch in runs], dtype=np.int64)
        codec = runs[0][1].codec
        for (_, ch), payload in zip(runs, codec.frames(names, F, k0, rows), strict=True):
            ch._deliver(payload, n)
