"""Fan-out of a run's samples to any number of watchers, as aligned frames.

Frame ``seq`` holds samples ``[seq F, (seq+1) F)`` (``F`` ≈ 20 ms of samples),
so "resume from sequence s" is sample ``s F``. A message carries one or more
whole frames (the last frame of a run may be short).

Each watcher is in one of two modes:

- **push** (default): frames are queued for it as they are published; when its
  queue holds ``max_frames`` it skips frames and is told so (``skipped``) when it
  catches up, and the run and the other watchers never wait for it;
- **pull** (after ``resume_from``): it reads from the recording at its own
  pace until it reaches the live edge, then goes back to push — so every
  missing sample arrives.

Everything here runs on the event loop thread; encoding is msgpack with
float32 columns.
"""

from __future__ import annotations

import asyncio
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

import msgpack
import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
Reader = Callable[[int, int], Awaitable[Array]]
FRAME_SECONDS = 0.02
PULL_FRAMES = 50  # frames per message while catching up from the recording


def frame_samples(Ts: float) -> int:
    """Samples per frame: about 20 ms of the run (at least one sample)."""
    return max(1, round(FRAME_SECONDS / Ts))


def pack(message: dict[str, Any]) -> bytes:
    return msgpack.packb(message, use_bin_type=True)  # type: ignore[no-any-return]


def encode_frame(names: tuple[str, ...], F: int, k0: int, data: Array) -> bytes:
    """One ``frame`` message: float32 little-endian column bytes per channel."""
    cols = np.ascontiguousarray(data.T, dtype="<f4")
    return pack({"type": "frame", "seq": k0 // F, "k0": k0, "n": int(data.shape[0]),
                 "columns": {name: cols[i].tobytes() for i, name in enumerate(names)}})


@dataclass(eq=False)  # identity: watchers live in sets
class Watcher:
    """One subscriber: a send function and its queue of pending messages."""

    send: Callable[[bytes], Awaitable[None]]
    max_frames: int = 100
    items: deque[tuple[bool, bytes]] = field(default_factory=deque)  # (is_frame, payload)
    frames_queued: int = 0
    skipped: tuple[int, int] | None = None  # first and last seq not delivered
    pull_from: int | None = None  # next sample to read from the recording
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    closed: bool = False

    def offer(self, payload: bytes, seq: int, frames: int) -> None:
        if self.pull_from is not None:
            return  # catching up from the recording
        if self.frames_queued >= self.max_frames:
            first = self.skipped[0] if self.skipped else seq
            self.skipped = (first, seq + frames - 1)
            return
        self.items.append((True, payload))
        self.frames_queued += 1
        self.wake.set()

    def control(self, payload: bytes) -> None:
        self.items.append((False, payload))
        self.wake.set()


class RunChannel:
    """The watchers of one run and the framing of its samples."""

    def __init__(self, names: tuple[str, ...], Ts: float, read: Reader, *, edge: int = 0,
                 ended: bool = False) -> None:
        self.names = names
        self.F = frame_samples(Ts)
        self.read = read
        self.edge = edge  # samples published as whole frames (or all, once ended)
        self.ended = ended
        self.watchers: set[Watcher] = set()
        self._pending: list[Array] = []
        self._pending_n = 0
        self._moved = asyncio.Event()

    def publish(self, k0: int, data: Array) -> None:
        """New samples (consecutive); complete frames go out now."""
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
        for w in self.watchers:
            w.control(payload)
        self._poke()

    def _emit(self, n: int) -> None:
        data = np.concatenate(self._pending) if len(self._pending) > 1 else self._pending[0]
        out, rest = data[:n], data[n:]
        self._pending = [rest] if rest.shape[0] else []
        self._pending_n = rest.shape[0]
        payload = encode_frame(self.names, self.F, self.edge, out)
        seq, frames = self.edge // self.F, -(-n // self.F)
        self.edge += n
        for w in self.watchers:
            w.offer(payload, seq, frames)
        self._poke()

    def _poke(self) -> None:
        self._moved.set()
        self._moved = asyncio.Event()

    def resume_from(self, w: Watcher, seq: int) -> None:
        """Serve ``w`` every sample from frame ``seq`` on, from the recording."""
        w.items = deque(item for item in w.items if not item[0])
        w.frames_queued, w.skipped = 0, None
        w.pull_from = min(max(0, seq) * self.F, self.edge)
        w.wake.set()

    async def serve(self, w: Watcher) -> None:
        """Send to ``w`` until it closes (the watcher's sender task)."""
        while not w.closed:
            if w.pull_from is not None:
                await self._pull(w)
                continue
            if not w.items:
                w.wake.clear()
                await w.wake.wait()
                continue
            if w.skipped is not None:
                first, last = w.skipped
                w.skipped = None
                await w.send(pack({"type": "skipped", "from_seq": first, "to_seq": last,
                                   "reason": "slow watcher: frames dropped; send resume_from "
                                             "to receive them from the recording"}))
            is_frame, payload = w.items.popleft()
            w.frames_queued -= is_frame
            await w.send(payload)

    async def _pull(self, w: Watcher) -> None:
        assert w.pull_from is not None
        if w.pull_from >= self.edge:
            w.pull_from = None  # caught up: live frames from here on
            if w.items:
                w.wake.set()
            return
        k1 = min(self.edge, w.pull_from + PULL_FRAMES * self.F)
        data = await self.read(w.pull_from, k1)
        if data.shape[0] == 0:  # not yet readable: wait for the recording to move
            moved = self._moved
            await moved.wait()
            return
        await w.send(encode_frame(self.names, self.F, w.pull_from, data))
        w.pull_from += data.shape[0]
