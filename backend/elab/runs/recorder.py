"""Every sample of every live run, kept until stored, then flushed in batches.

The stepping thread appends chunks; a writer thread moves them to the
:class:`~elab.runs.store.Store` every ``interval`` seconds in one transaction;
readers see stored and not-yet-stored samples as one consecutive recording.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from elab.runs.store import Store

Array = NDArray[np.float64]


@dataclass
class _Tail:
    nch: int
    stored: int = 0  # samples committed to the store
    chunks: list[tuple[int, Array]] = field(default_factory=list)  # not yet committed


class Recorder:
    """In-memory tails of the live runs in front of the store."""

    def __init__(self, store: Store, interval: float = 0.25) -> None:
        self.store = store
        self.interval = interval
        self._lock = threading.Lock()
        self._tails: dict[str, _Tail] = {}
        self._stop = threading.Event()
        self._flushing = threading.Lock()
        self._thread = threading.Thread(target=self._loop, name="elab-writer", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10)
        self.flush()

    def open(self, run_id: str, nch: int) -> None:
        with self._lock:
            self._tails[run_id] = _Tail(nch)

    def append_many(self, run_ids: list[str], k0: list[int], data: Array) -> None:
        """Rows ``k0[i] ..`` of run ``run_ids[i]``: ``data[i]`` (runs × n × channels)."""
        with self._lock:
            tails = self._tails
            for run_id, k, rows in zip(run_ids, k0, data, strict=True):
                tails[run_id].chunks.append((k, rows))

    def finish(self, run_id: str) -> None:
        """Store what is left of ``run_id`` now and stop tracking it."""
        self.flush()
        with self._lock:
            self._tails.pop(run_id, None)

    def read(self, run_id: str, k0: int, k1: int) -> Array:
        """Samples ``[k0, k1)`` that exist so far, stored or not."""
        with self._lock:
            tail = self._tails.get(run_id)
            chunks = list(tail.chunks) if tail else []
            stored = tail.stored if tail else None
        if stored is None:
            return self.store.read(run_id, k0, k1)
        parts = [self.store.read(run_id, k0, min(k1, stored))] if k0 < stored else []
        for c0, data in chunks:
            lo, hi = max(k0, c0), min(k1, c0 + data.shape[0])
            if lo < hi:
                parts.append(data[lo - c0:hi - c0])
        if not parts:
            return np.zeros((0, tail.nch if tail else 0))
        return np.concatenate(parts) if len(parts) > 1 else parts[0]

    def flush(self) -> None:
        """Commit every pending chunk in one transaction."""
        with self._flushing:
            with self._lock:  # one row per run per flush: its pending chunks joined
                batch = [(rid, t.chunks[0][0], _joined([d for _, d in t.chunks]))
                         for rid, t in self._tails.items() if t.chunks]
                batch = [item for item in batch if item[2].shape[0]]
                counts = {rid: len(t.chunks) for rid, t in self._tails.items()}
            if batch:
                self.store.append_many(batch)
            with self._lock:
                for rid, n in counts.items():
                    tail = self._tails.get(rid)
                    if tail is None:
                        continue
                    done, tail.chunks = tail.chunks[:n], tail.chunks[n:]
                    tail.stored += sum(d.shape[0] for _, d in done)

    def _loop(self) -> None:
        while not self._stop.wait(self.interval):
            self.flush()


def _joined(parts: list[Array]) -> Array:
    return parts[0] if len(parts) == 1 else np.concatenate(parts)
