"""An engine's writes: every sample and record change of its runs, kept until committed.

The stepping thread appends samples and queues record changes (pause, resume,
parameters, the end); a writer thread commits them every ``interval`` seconds
(the samples of all runs in one transaction, then the changes in order), so a
crash loses at most that interval.

Faults: a transient :class:`~elab.store.base.StoreError` (another writer holds
the lock) is retried with back-off while the data wait in memory. One that is
not transient, or a transient one that lasts ``retry_for`` seconds or lets
``max_pending`` bytes pile up, is a *failure*: ``on_fault`` hears of it (the
engine fails its live runs with the reason), samples not yet committed are
dropped — the recordings keep everything committed before — and the changes
still queued (the runs' final states) are retried every second, as is a probe
write when nothing is queued, until the store works again.

A run's end is a step of the recording: its final state is written only after every
sample it produced is committed, and a run that ends with fewer samples committed than
it produced (the store failed meanwhile) is recorded as such — ``finished`` becomes
``failed`` with the count and the store's error. ``on_ended`` hears that decision
(which cannot change: the samples are committed, or dropped with a failed store),
``on_stored`` that the record holds it (for a failed store, once it works again).
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from elab.engines.base import Block, Ended, EngineEvents, StoreHealth
from elab.engines.outcome import OutcomeTracker
from elab.errors import ElabError
from elab.lifecycle import RunState
from elab.store.base import ParamChange, RunStore, StoreError

log = logging.getLogger(__name__)

Array = NDArray[np.float64]
_RETRY_CAP = 2.0  # s: the longest back-off between two tries
_FAILED_RETRY = 1.0  # s: how often a failed store is tried again


@dataclass
class _Tail:
    nch: int
    stored: int = 0  # samples committed to the store
    chunks: list[tuple[int, Array]] = field(default_factory=list)  # not yet committed
    outcome: OutcomeTracker | None = None  # follows the committed samples, in order

    @property
    def pending_bytes(self) -> int:
        return sum(d.nbytes for _, d in self.chunks)


@dataclass(frozen=True)
class _Status:
    run_id: str
    state: RunState
    error: str | None
    final: bool
    compute: dict[str, float | int] | None = None
    k: int | None = None  # samples the run produced, for its end
    ended: Ended | None = None  # its end as decided (the samples committed), for the store


@dataclass(frozen=True)
class _Param:
    run_id: str
    change: ParamChange


class Flushing(Protocol):
    """An engine's settings for its recorder (both engines' settings have them)."""

    @property
    def flush_interval(self) -> float: ...

    @property
    def retry_for(self) -> float: ...

    @property
    def max_pending(self) -> int: ...


class Recorder:
    """The writer thread of one engine and what waits for it."""

    def __init__(
        self,
        store: RunStore,
        *,
        interval: float = 0.25,
        retry_for: float = 30.0,
        max_pending: int = 256 << 20,
        on_committed: Callable[[dict[str, int]], None] = lambda counts: None,
        on_ended: Callable[[str, Ended], None] = lambda run_id, ended: None,
        on_stored: Callable[[str], None] = lambda run_id: None,
        on_fault: Callable[[StoreHealth], None] = lambda health: None,
    ) -> None:
        self.store = store
        self.interval = interval
        self.retry_for = retry_for
        self.max_pending = max_pending
        self._on_committed = on_committed
        self._on_ended = on_ended
        self._on_stored = on_stored
        self._on_fault = on_fault
        self._lock = threading.Lock()
        self._tails: dict[str, _Tail] = {}
        self._blocks: list[Block] = []  # appended, not yet sorted into the tails
        self._ops: deque[_Status | _Param] = deque()
        self._flushing = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="elab-writer", daemon=True)
        self.health = StoreHealth()
        self.last_flush = time.monotonic()  # the end of the writer's last try (its watchdog)

    @classmethod
    def reporting(
        cls,
        store: RunStore,
        engine_id: str,
        events: EngineEvents,
        settings: Flushing,
        on_fault: Callable[[StoreHealth], None],
    ) -> Recorder:
        """The recorder of engine ``engine_id`` with its ``settings``' flush interval,
        retry time and memory budget, reporting what it commits, decides and stores to
        ``events``."""
        return cls(
            store,
            interval=settings.flush_interval,
            retry_for=settings.retry_for,
            max_pending=settings.max_pending,
            on_committed=lambda counts: events.committed(engine_id, counts),
            on_ended=lambda run_id, ended: events.ended(engine_id, run_id, ended),
            on_stored=lambda run_id: events.stored(engine_id, run_id),
            on_fault=on_fault,
        )

    @property
    def failed(self) -> bool:
        """The store has failed (not a transient fault being retried)."""
        return not self.health.ok and not self.health.transient

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        """Stop the thread and make a last try to commit everything."""
        self._stop.set()
        self._thread.join(timeout=30)
        try:
            self.flush()
        except StoreError as exc:
            log.error("closing with data not stored: %s", exc)

    # -- from the engine (any thread) -------------------------------------------
    def open(self, run_id: str, nch: int, outcome: OutcomeTracker | None = None) -> None:
        """A new run of ``nch`` columns; ``outcome`` follows its samples as they are
        committed (on the writer thread), and its marks are stored with the run's end."""
        with self._lock:
            self._tails[run_id] = _Tail(nch, outcome=outcome)

    def append(self, block: Block) -> None:
        """A block of new samples (rows ``k0[i] ..`` of run ``run_ids[i]`` in ``data[i]``).
        Kept whole, at no cost per run to the stepping thread; the writer sorts the rows
        by run. Dropped while the store has failed (those runs are being failed)."""
        with self._lock:
            if not self.failed:
                self._blocks.append(block)

    def status(
        self,
        run_id: str,
        state: RunState,
        error: str | None = None,
        compute: dict[str, float | int] | None = None,
        k: int | None = None,
    ) -> None:
        """Record a change of state (``compute``: a code controller's times, with its end);
        ``state`` final: the run's last write, after its ``k`` samples (every block
        appended before this call) are committed."""
        with self._lock:
            self._ops.append(
                _Status(run_id, state, error, final=not state.live, compute=compute, k=k)
            )
            if self.failed and not state.live:
                self._sort_blocks()
                tail = self._tails.get(run_id)
                if tail is not None:
                    tail.chunks = []

    def param(self, run_id: str, change: ParamChange) -> None:
        with self._lock:
            self._ops.append(_Param(run_id, change))

    def pending_bytes(self) -> int:
        with self._lock:
            return sum(t.pending_bytes for t in self._tails.values()) + sum(
                b.data.nbytes for b in self._blocks
            )

    def _sort_blocks(self) -> None:
        """Move the appended blocks' rows to their runs' tails (the lock held). The blocks
        of the same runs that follow on from each other (each tick's block of a plant, while
        no run joins or leaves) are joined first, with one copy for all their runs, so a
        run gets one chunk per flush, not one per tick (at 300 runs the rows one by one took
        a third of the writer's time)."""
        tails = self._tails
        for run_ids, k0, data in _segments(self._blocks):
            for run_id, k, rows in zip(run_ids, k0, data, strict=True):
                tail = tails.get(run_id)
                if tail is not None:
                    tail.chunks.append((k, rows))
        self._blocks = []

    # -- the writer ---------------------------------------------------------------
    def flush(self) -> None:
        """Commit every pending chunk (one transaction), then the queued changes in order;
        raises :class:`StoreError` (what is not committed stays queued)."""
        with self._flushing:
            self._flush_samples()
            self._flush_ops()

    def _flush_samples(self) -> None:
        with self._lock:  # one row per run per flush: its pending chunks joined
            self._sort_blocks()
            batch = [
                (rid, t.chunks[0][0], _joined([d for _, d in t.chunks]))
                for rid, t in self._tails.items()
                if t.chunks
            ]
            counts = {rid: len(t.chunks) for rid, t in self._tails.items()}
        if not batch:
            return
        self.store.append_many(batch)
        stored: dict[str, int] = {}
        trackers: dict[str, OutcomeTracker] = {}
        with self._lock:
            for rid, n in counts.items():
                tail = self._tails.get(rid)
                if tail is None or not n:
                    continue
                done, tail.chunks = tail.chunks[:n], tail.chunks[n:]
                tail.stored += sum(d.shape[0] for _, d in done)
                stored[rid] = tail.stored
                if tail.outcome is not None:
                    trackers[rid] = tail.outcome
        for rid, k0, data in batch:  # (this thread alone feeds them: not under the lock)
            if rid in trackers:
                trackers[rid].add(k0, data)
        self._on_committed(stored)

    def _flush_ops(self) -> None:
        while True:
            with self._lock:
                if not self._ops:
                    return
                op = self._ops[0]
            if isinstance(op, _Status) and op.final and op.ended is None:
                op = self._decide_end(op)  # its samples first (may raise StoreError)
                with self._lock:
                    self._ops[0] = op
                assert op.ended is not None
                self._on_ended(op.run_id, op.ended)
            try:
                if isinstance(op, _Param):
                    self.store.add_param_change(op.run_id, op.change)
                else:
                    self.store.set_status(
                        op.run_id,
                        op.state.value,
                        error=op.error if op.final else None,  # a pause's reason is news only
                        finished_at=time.time() if op.final else None,
                        compute=op.compute,
                        outcome=self._outcome(op.run_id) if op.final else None,
                    )
            except StoreError:
                raise
            except ElabError:  # the run is not in the store (a bug): nothing to retry
                log.exception("dropping a record change of run %s", op.run_id)
            with self._lock:
                self._ops.popleft()
                if isinstance(op, _Status) and op.final:
                    self._tails.pop(op.run_id, None)
            if isinstance(op, _Status) and op.final:
                self._on_stored(op.run_id)

    def _outcome(self, run_id: str) -> list[dict[str, Any]] | None:
        """The marks of an ending run's committed samples (``None``: not followed)."""
        with self._lock:
            tail = self._tails.get(run_id)
            tracker = tail.outcome if tail is not None else None
        return None if tracker is None else tracker.marks()

    def _decide_end(self, op: _Status) -> _Status:
        """Commit the ending run's samples still waiting (raises :class:`StoreError`), then
        decide its end as the store will hold it: ``finished`` only with every sample it
        produced committed; otherwise ``failed``, or its own end, saying how many were.
        Decided once: a store that then fails keeps the decision for its retries."""
        with self._lock:
            self._sort_blocks()
            tail = self._tails.get(op.run_id)
            waiting = tail is not None and bool(tail.chunks)
        if waiting:
            self._flush_samples()
        with self._lock:
            tail = self._tails.get(op.run_id)
            stored = tail.stored if tail is not None else (op.k or 0)
        if op.k is not None and stored < op.k:
            lost = f"only {stored} of its {op.k} samples could be stored"
            if self.health.error:
                lost += f" (the store: {self.health.error})"
            if op.state is RunState.FINISHED:
                op = replace(op, state=RunState.FAILED, error=lost)
            else:
                op = replace(op, error=f"{op.error}; {lost}" if op.error else lost)
        return replace(op, ended=Ended(op.state, op.error, stored))

    def _loop(self) -> None:
        delay = self.interval
        while not self._stop.wait(delay):
            try:
                self.flush()
                if not self.health.ok:
                    self.store.probe()  # nothing was queued: show that writing works
                    self._set_health(StoreHealth())
                delay = self.interval
            except StoreError as exc:
                delay = self._fault(exc, delay)
            except Exception:  # a bug: reported, and the thread goes on trying
                log.exception("the writer failed")
                self._set_health(
                    StoreHealth(
                        ok=False,
                        error="internal error in the writer (see the server log)",
                        since=time.time(),
                    )
                )
                delay = _FAILED_RETRY
            finally:
                self.last_flush = time.monotonic()

    def _fault(self, exc: StoreError, delay: float) -> float:
        now = time.time()
        since = self.health.since or now
        pending = self.pending_bytes()
        give_up = not exc.transient or now - since >= self.retry_for or pending > self.max_pending
        if give_up:
            with self._lock:  # the runs fail; what was not committed cannot be
                self._blocks = []
                for tail in self._tails.values():
                    tail.chunks = []
                pending = 0
        self._set_health(
            StoreHealth(
                ok=False, error=str(exc), since=since, transient=not give_up, pending_bytes=pending
            )
        )
        return _FAILED_RETRY if give_up else min(max(self.interval, 2 * delay), _RETRY_CAP)

    def _set_health(self, health: StoreHealth) -> None:
        changed = (health.ok, health.transient) != (self.health.ok, self.health.transient)
        self.health = health
        if changed:
            log.warning("store: %s", "ok" if health.ok else health.error)
            self._on_fault(health)


def _segments(blocks: list[Block]) -> list[tuple[list[str], list[int], Array]]:
    """``blocks`` as few as can be: each with the blocks of the same runs that follow on
    from it joined along time."""
    parts: list[list[Block]] = []
    open_: dict[tuple[str, ...], int] = {}  # runs → their segment that may go on
    for b in blocks:
        key = tuple(b.run_ids)
        i = open_.get(key)
        if i is not None:
            last = parts[i][-1]
            n = last.data.shape[1]
            if all(k == k0 + n for k, k0 in zip(b.k0, last.k0, strict=True)):
                parts[i].append(b)
                continue
        open_[key] = len(parts)
        parts.append([b])
    return [
        (
            p[0].run_ids,
            p[0].k0,
            p[0].data if len(p) == 1 else np.concatenate([b.data for b in p], 1),
        )
        for p in parts
    ]


def _joined(parts: list[Array]) -> Array:
    return parts[0] if len(parts) == 1 else np.concatenate(parts)
