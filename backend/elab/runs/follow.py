"""Runs as the web process follows them: it hears the engines (:class:`RunFollower`
implements :class:`~elab.engines.base.EngineEvents`), keeps each live run (its record,
order and parameters, its state, the samples not yet stored) and its channel to watchers,
and reads recordings joining the store with what it has not committed yet.

New samples go to the run's channel (and to a short in-memory tail of what the store has
not committed yet, so a watcher catching up reads one consecutive recording), state
changes to its watchers. A run the engine has ended stays here until the engine reports
its final record stored, and only then do its watchers hear how it ended, with the
samples the recording holds (a run is ``finished`` only with all of them stored); after
that the store answers. Samples that arrive after a gap (the engine dropped blocks while
this process did not read) wait while the gap is read back from the store.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elab.engines.base import Block, Changed, Ended, Engine, Health, NewParams, RunOrder
from elab.errors import ElabError
from elab.lifecycle import RunState
from elab.runs.changes import RunParams
from elab.runs.fanout import Codec, RunChannel, Sender, publish_block
from elab.runs.live import LiveRun, Reader, stored_reader
from elab.store.base import ParamChange, RunRecord, RunStore

log = logging.getLogger(__name__)

Array = NDArray[np.float64]


class RunFollower:
    """The live runs of this web process, as their engines report them."""

    def __init__(self, store: RunStore, codec: Codec) -> None:
        self.store = store
        self.codec = codec
        self._runs: dict[str, LiveRun] = {}
        self._channels: dict[str, RunChannel] = {}
        self._sender = Sender()  # one pass over all watchers per tick
        self._ordered: dict[str, RunOrder] = {}  # runs being started, until they start
        self._tasks: set[asyncio.Task[object]] = set()

    async def _add(self, engine: Engine, order: RunOrder) -> RunRecord:
        """Start ``order`` on ``engine``; its engine's ``started`` finds it here."""
        self._ordered[order.id] = order
        try:
            return await engine.add(order)
        finally:
            self._ordered.pop(order.id, None)

    # -- recordings and channels ---------------------------------------------------
    async def read(self, run_id: str, k0: int = 0, k1: int | None = None) -> Array:
        """Samples ``[k0, k1)`` recorded so far (``None``: to the end), stored or not yet."""
        return await asyncio.to_thread(self.snapshot(run_id), k0, k1)

    def durable(self, run_id: str) -> tuple[int | None, Reader]:
        """What a download gives: the samples in the store now — ``n``, or ``None`` for a run
        this process no longer follows (all of it) — and a reader of them. A sample streamed
        but not yet stored could still be lost (its engine killed, its store failed)."""
        run = self._runs.get(run_id)
        if run is None:
            return None, stored_reader(self.store, run_id)
        return run.committed, run.durable_reader(self.store)

    def snapshot(self, run_id: str) -> Reader:
        """A reader of the recording as it is now, callable from any thread (see
        :meth:`LiveRun.reader`)."""
        run = self._runs.get(run_id)
        return stored_reader(self.store, run_id) if run is None else run.reader(self.store)

    def channel(self, record: RunRecord) -> RunChannel:
        """The live channel of a run, or a replay channel over its recording."""
        ch = self._channels.get(record.id)
        if ch is None:
            ch = RunChannel(
                tuple(n for n, _ in record.channels),
                record.Ts,
                self._reader(record.id),
                self.codec,
                edge=record.n_stored,
                ended=True,
                sender=self._sender,
            )
            self._channels[record.id] = ch
        return ch

    def release(self, run_id: str, channel: RunChannel) -> None:
        """Forget a channel once nobody watches it and its run is over."""
        run = self._runs.get(run_id)
        if not channel.watchers and (run is None or not run.state.live):
            self._channels.pop(run_id, None)

    def _reader(self, run_id: str) -> Callable[[int, int], Awaitable[Array]]:
        async def read(k0: int, k1: int) -> Array:
            return await self.read(run_id, k0, k1)

        return read

    # -- events from the engines (on the loop) ----------------------------------------
    def started(self, engine: str, record: RunRecord, order: RunOrder | None = None) -> None:
        """A run to follow: one this process ordered, or, on a broker, one another web
        process ordered, or one its engine says again for a web process that started after
        it (``follow``: from the samples stored by then; said twice: followed once)."""
        if record.id in self._runs:
            return
        mine = self._ordered.get(record.id)
        order = mine or order
        if order is None:
            log.error("run %s started without its order: not followed here", record.id)
            return
        names = tuple(n for n, _ in record.channels)
        ch = RunChannel(names, record.Ts, self._reader(record.id), self.codec, sender=self._sender)
        self._channels[record.id] = ch
        params = RunParams(order.spec.law, order.spec.reference)
        run = self._runs[record.id] = LiveRun(record, engine, ch, order, params)
        if mine is None and record.n_stored:  # joined mid-run: the store has the start
            ch.edge = run.next_k = record.n_stored // ch.F * ch.F
            run.committed = record.n_stored

    def blocks(self, engine: str, blocks: list[Block]) -> None:
        runs = self._runs
        for b in blocks:
            n = b.data.shape[1]
            channels: list[RunChannel | None] = []
            for i, (run_id, k0) in enumerate(zip(b.run_ids, b.k0, strict=True)):
                run = runs.get(run_id)
                if run is None or run.filling is not None or k0 != run.next_k:
                    channels.append(None)
                    if run is not None:
                        self._out_of_line(run, k0, b.data[i])
                    continue
                run.next_k = k0 + n
                run.recent.append((k0, b.data[i]))
                channels.append(run.channel)
            publish_block(channels, b.data)

    def changed(self, engine: str, change: Changed) -> None:
        run = self._runs.get(change.run_id)
        if run is None:
            return
        if not change.state.live:  # said when its record is stored: stored()
            run.ending = True
            return
        run.state = change.state
        run.error = change.error  # while paused: who paused it or why, for late joiners
        run.channel.control(self.codec.status(change.state.value, run.next_k, change.error))

    def params(
        self, engine: str, run_id: str, change: ParamChange, new: NewParams | None = None
    ) -> None:
        run = self._runs.get(run_id)
        if run is None:
            return
        if new is not None:  # whoever changed it: the law and reference it uses now
            run.params = run.params.after(new)
        run.changes.append(change)
        run.channel.control(self.codec.params(change.k, change.k * run.record.Ts, change.params))

    def committed(self, engine: str, counts: dict[str, int]) -> None:
        for run_id, n in counts.items():
            run = self._runs.get(run_id)
            if run is None:
                continue
            run.committed = n
            run.recent = [(c0, rows) for c0, rows in run.recent if c0 + rows.shape[0] > n]
            run.moved.set()
            run.channel.moved()

    def ended(self, engine: str, run_id: str, ended: Ended) -> None:
        """The run's end as decided with its samples stored: to its watchers, with how
        many the recording holds."""
        run = self._runs.get(run_id)
        if run is None or run.settled.is_set():
            return
        run.state, run.error, run.final_k = ended.state, ended.error, ended.n
        run.settled.set()
        run.moved.set()
        status = self.codec.status(ended.state.value, ended.n, ended.error)
        if run.filling is not None:
            run.end_status = status  # sent once the gap is filled
        else:
            self._end(run, status)

    def stored(self, engine: str, run_id: str) -> None:
        """The run's final record is in the store: from now on the store answers."""
        run = self._runs.get(run_id)
        if run is None:
            return
        if not run.settled.is_set():  # its end was missed (resync): the store says it
            self._spawn(self._settle_from_store(engine, [run]))
            return
        run.stored = True
        if run.filling is None:
            self._forget(run)

    def resync(self, engine: str) -> None:
        """Ends of the engine's runs this process missed, from their records."""
        runs = [r for r in self._runs.values() if r.engine == engine and not r.stored]
        if runs:
            self._spawn(self._settle_from_store(engine, runs))

    async def _settle_from_store(self, engine: str, runs: list[LiveRun]) -> None:
        """Each of ``runs`` whose record in the store says it has ended ends here so."""
        for run in runs:
            try:
                r = await asyncio.to_thread(self.store.get_run, run.record.id)
            except ElabError:
                log.exception("could not read run %s to follow its end", run.record.id)
                continue
            if RunState(r.status).live or run.stored:
                continue
            self.ended(engine, r.id, Ended(RunState(r.status), r.error, r.n_stored))
            run.stored = True
            if run.filling is None:
                self._forget(run)

    def health(self, engine: str, health: Health) -> None:
        pass  # the engine keeps its last heartbeat; GET /server and /health read it there

    def lost(self, engine: str, reason: str) -> None:
        """The engine died: its runs not yet stored are interrupted, with what it had
        committed (their watchers hear it with the store's count)."""
        lost = [r for r in self._runs.values() if r.engine == engine and not r.stored]
        for run in lost:
            run.ending = True
        self._spawn(self._store_lost(engine, reason, lost))

    async def _store_lost(self, engine: str, reason: str, runs: list[LiveRun]) -> None:
        try:
            await asyncio.to_thread(self.store.mark_interrupted, engine, reason)
            records = [await asyncio.to_thread(self.store.get_run, r.record.id) for r in runs]
            ends = [Ended(RunState(r.status), r.error, r.n_stored) for r in records]
        except ElabError:  # the engine marks them when it starts again; the log says why
            log.exception("could not mark the runs of engine %s interrupted", engine)
            ends = [Ended(RunState.INTERRUPTED, reason, r.committed) for r in runs]
            for run, ended in zip(runs, ends, strict=True):
                self.ended(engine, run.record.id, ended)
            return
        for run, ended in zip(runs, ends, strict=True):
            self.ended(engine, run.record.id, ended)
            self.stored(engine, run.record.id)

    # -- internals -----------------------------------------------------------------
    def _end(self, run: LiveRun, status: bytes) -> None:
        run.channel.end(status)
        if run.stored:
            self._forget(run)

    def _forget(self, run: LiveRun) -> None:
        self._runs.pop(run.record.id, None)
        run.forgotten.set()
        self.release(run.record.id, run.channel)

    def _out_of_line(self, run: LiveRun, k0: int, rows: Array) -> None:
        """Samples that do not follow the last ones: held while the gap before them (the
        engine dropped blocks while this process did not read) is read from the store."""
        if run.filling is not None:
            run.filling.append((k0, rows))
        elif k0 > run.next_k:
            log.warning(
                "run %s: samples %d..%d did not arrive; reading them from the store",
                run.record.id,
                run.next_k,
                k0,
            )
            run.filling = [(k0, rows)]
            self._spawn(self._fill(run, k0))
        # k0 < next_k: samples already published (cannot happen in order); ignored

    async def _fill(self, run: LiveRun, gap_end: int) -> None:
        while run.committed < gap_end and run.state.live:
            run.moved.clear()
            await run.moved.wait()
        end = min(gap_end, run.committed)
        if end > run.next_k:
            data = await asyncio.to_thread(self.store.read, run.record.id, run.next_k, end)
            run.channel.publish(data)
            run.next_k += data.shape[0]
        held, run.filling = run.filling or [], None
        for k0, rows in held:
            if k0 == run.next_k:
                run.recent.append((k0, rows))
                run.channel.publish(rows)
                run.next_k += rows.shape[0]
        if run.end_status is not None:
            self._end(run, run.end_status)
        elif run.stored:
            self._forget(run)

    def _spawn(self, coro: Coroutine[Any, Any, object]) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
