"""A run the web process follows: its record and order as started, the law and reference
it uses now, its state and progress as the engine reports them, the samples received but
not yet stored, and readers of its recording that join the two."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from elab.engines.base import RunOrder
from elab.lifecycle import RunState
from elab.runs.changes import RunParams
from elab.runs.fanout import RunChannel
from elab.store.base import ParamChange, RunRecord, RunStore

Array = NDArray[np.float64]
Reader = Callable[..., Array]  # (k0, k1=None) -> samples [k0, k1)


@dataclass(eq=False)
class LiveRun:
    """A run this process has heard of from its engine and not yet seen stored."""

    record: RunRecord  # as started; status and progress below
    engine: str
    channel: RunChannel
    order: RunOrder  # what it was started with, typed
    params: RunParams  # the law and reference its loop uses now
    state: RunState = RunState.RUNNING
    ending: bool = False  # its engine ended it; how is decided once its samples are stored
    final_k: int = 0  # an ended run's samples in the store
    seen: float = field(default_factory=time.monotonic)  # its owner was last connected
    idle_paused: bool = False  # paused because nobody watched it
    error: str | None = None
    next_k: int = 0  # the next sample expected from the engine
    committed: int = 0  # samples [0, committed) are in the store
    recent: list[tuple[int, Array]] = field(default_factory=list)  # received, not committed
    changes: list[ParamChange] = field(default_factory=list)
    filling: list[tuple[int, Array]] | None = None  # blocks held while a gap is read back
    end_status: bytes | None = None  # the final status, held back while filling
    settled: asyncio.Event = field(default_factory=asyncio.Event)  # its end is decided
    stored: bool = False  # its final record is in the store
    moved: asyncio.Event = field(default_factory=asyncio.Event)  # committed grew / it ended
    forgotten: asyncio.Event = field(default_factory=asyncio.Event)  # stored; the store answers

    def current(self) -> RunRecord:
        return replace(
            self.record,
            status=self.state.value,
            n_stored=self.next_k if self.state.live else self.final_k,
            error=self.error or self.record.error,
        )

    def durable_reader(self, store: RunStore) -> Reader:
        """A reader of the samples in the store now (``committed`` of them)."""
        run_id, n = self.record.id, self.committed
        return lambda k0, k1=None: store.read(run_id, k0, n if k1 is None else min(k1, n))

    def reader(self, store: RunStore) -> Reader:
        """A reader of the recording as it is now, callable from any thread: ``read(k0, k1)``
        gives samples ``[k0, min(k1, n))``, ``n`` the samples recorded when it was taken
        (the store's committed part, then this process's copy of the rest)."""
        run_id = self.record.id
        committed, recent, end = self.committed, list(self.recent), self.next_k
        nch = len(self.record.channels)

        def read(k0: int, k1: int | None = None) -> Array:
            stop = end if k1 is None else min(k1, end)
            parts = [store.read(run_id, k0, min(stop, committed))] if k0 < committed else []
            at = k0 + sum(p.shape[0] for p in parts)
            for c0, rows in recent:
                if c0 <= at < c0 + rows.shape[0] and at < stop:
                    parts.append(rows[at - c0 : min(stop, c0 + rows.shape[0]) - c0])
                    at += parts[-1].shape[0]
            if not parts:
                return np.zeros((0, nch))
            return np.concatenate(parts) if len(parts) > 1 else parts[0]

        return read


def stored_reader(store: RunStore, run_id: str) -> Reader:
    """A reader of a run this process no longer follows: the store has all of it."""
    return lambda k0, k1=None: store.read(run_id, k0, k1)
