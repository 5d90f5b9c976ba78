"""Run lifecycle on the web side: start runs on an engine, follow them, fan them out.

The manager lives on the event loop. It starts a run on the engine of its mode
(:class:`Engines`: simulation, rig) and sends every later command to the engine that
steps it, as recorded with the run (the engine decides them, records everything and
answers), and hears from it through :class:`~elab.engines.base.EngineEvents`: new
samples go to the run's channel (and to a short in-memory tail of what the store has
not committed yet, so a watcher catching up reads one consecutive recording), state
changes go to its watchers. A run the engine has ended stays here until
the engine reports its final record stored, and only then do its watchers and
clients hear how it ended, with the samples the recording holds (a run is
``finished`` only with all of them stored); after that the store answers.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import secrets
import time
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elab.access import Identity, may_view, require_control
from elab.engines.base import (
    Action,
    Block,
    Changed,
    Ended,
    Engine,
    EngineStatus,
    Health,
    Pace,
    RunOrder,
)
from elab.errors import Conflict, ElabError, InvalidInput, NotFound, Unavailable
from elab.lifecycle import RunState
from elab.runs.changes import Applied, Change, RunParams, decide
from elab.runs.fanout import Codec, RunChannel, Sender, publish_block
from elab.runs.limits import Limits
from elab.runs.live import LiveRun, Reader, stored_reader
from elab.runs.patrol import Patrol
from elab.sim.spec import RunSpec
from elab.store.base import JsonObject, ParamChange, RunRecord, RunStore, RunSummary

log = logging.getLogger(__name__)

Array = NDArray[np.float64]
END_WAIT = 10.0  # s: how long a stop waits for the run's end to be stored before answering


def new_run_id() -> str:
    return f"r-{secrets.token_hex(6)}"


def _no_longer_steps(run_id: str, status: str) -> Conflict:
    return Conflict(f"run {run_id} has ended ({status}): it no longer steps")


#: The engines of a server by the mode of the runs they step (``"simulation"``, ``"rig"``).
Engines = Mapping[str, Engine]


@dataclass(frozen=True)
class ManagerStatus:
    """Live runs, connected watchers, and each engine as it reports itself, by mode."""

    live_runs: int
    watchers: int
    engines: dict[str, EngineStatus]


class RunManager:
    """All runs as this web process sees them; implements ``EngineEvents``."""

    def __init__(
        self, store: RunStore, engines: Engines, codec: Codec, *, limits: Limits | None = None
    ) -> None:
        if "simulation" not in engines:
            raise ValueError("a run manager needs a simulation engine")
        self.store = store
        self.engines = dict(engines)
        self._by_id = {e.id: e for e in engines.values()}
        self.codec = codec
        self.limits = limits or Limits()
        self._runs: dict[str, LiveRun] = {}
        self._channels: dict[str, RunChannel] = {}
        self._sender = Sender()  # one pass over all watchers per tick
        self._starting: Counter[str | None] = Counter()  # runs being started, by owner
        self._ordered: dict[str, RunOrder] = {}  # runs being started, until they start
        self._downloads: Counter[str] = Counter()  # downloads under way, by run
        self._deleted: set[str] = set()  # deleted while downloaded: removed after the last
        self._tasks: set[asyncio.Task[None]] = set()
        self._patrol_task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        for engine in self.engines.values():
            await engine.start(self)
        patrol = Patrol(self._runs, self.limits, self.store, self._command, self._remove)
        self._patrol_task = asyncio.get_running_loop().create_task(patrol.run())

    async def close(self) -> None:
        if self._patrol_task is not None:
            self._patrol_task.cancel()
            await asyncio.gather(self._patrol_task, return_exceptions=True)
        for engine in self.engines.values():
            await engine.close()

    # -- queries ---------------------------------------------------------------
    @property
    def live_count(self) -> int:
        return sum(r.state.live for r in self._runs.values())

    def status(self) -> ManagerStatus:
        return ManagerStatus(
            live_runs=self.live_count,
            watchers=sum(len(ch.watchers) for ch in self._channels.values()),
            engines={mode: e.status() for mode, e in self.engines.items()},
        )

    def engine_for(self, mode: str) -> Engine:
        """The engine that steps runs of ``mode``; :class:`InvalidInput` for a mode this
        server has none for."""
        engine = self.engines.get(mode)
        if engine is None:
            if mode == "rig":
                allowed = "simulation (no rig is configured on this server: ELAB_RIG)"
            else:
                allowed = " or ".join(sorted(self.engines))
            raise InvalidInput("mode", mode, allowed)
        return engine

    def _engine_of(self, run_id: str) -> Engine:
        """The engine stepping a live run (the one recorded with it)."""
        run = self._runs.get(run_id)
        if run is None:
            raise Conflict(f"run {run_id} is not live")
        engine = self._by_id.get(run.engine)
        if engine is None:
            raise Unavailable(f"run {run_id}: its engine {run.engine} is not known here")
        return engine

    async def get(self, run_id: str, who: Identity | None = None) -> RunRecord:
        """A run as it is now; given ``who``, :class:`NotFound` for a private run of
        someone else (as if it did not exist)."""
        if run_id in self._deleted:
            raise NotFound("run", run_id)
        run = self._runs.get(run_id)
        record = run.current() if run is not None else None
        if record is None:
            record = await asyncio.to_thread(self.store.get_run, run_id)
        if who is not None and not may_view(who, record.owner, record.private):
            raise NotFound("run", run_id)
        if who is not None and run is not None and who.id and who.id == record.owner:
            run.seen = time.monotonic()  # its owner asked about it: someone is there
        return record

    async def page(
        self,
        *,
        who: Identity,
        plant: str | None = None,
        owner: str | None = None,
        limit: int = 50,
        offset: int = 0,
    ) -> tuple[list[RunSummary], int]:
        """A page of the runs ``who`` may see (of ``owner`` if given), newest first, live
        ones with their current state."""
        runs, total = await asyncio.to_thread(
            self.store.list_runs,
            plant=plant,
            owner=owner,
            viewer=None if who.instructor else who.id,
            limit=limit,
            offset=offset,
        )
        shown = [r for r in runs if r.id not in self._deleted]
        total -= len(runs) - len(shown)
        return [self._runs[r.id].current() if r.id in self._runs else r for r in shown], total

    def live_runs(self) -> list[RunRecord]:
        """Every live run, oldest first (for instructors)."""
        return sorted(
            (r.current() for r in self._runs.values() if r.state.live),
            key=lambda r: r.created_at,
        )

    async def param_changes(self, run_id: str) -> list[ParamChange]:
        run = self._runs.get(run_id)
        if run is not None:
            return list(run.changes)
        return await asyncio.to_thread(self.store.param_changes, run_id)

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

    # -- lifecycle ---------------------------------------------------------------
    async def create(
        self,
        spec: RunSpec,
        *,
        pace: Pace,
        mode: str,
        experiment: str,
        request: JsonObject,
        who: Identity,
        private: bool = False,
    ) -> RunRecord:
        """Check the run against the limits and start it on the engine, owned by ``who``."""
        plant = spec.plant
        nch = 2 + plant.ny + plant.nx
        self.limits.check(spec, nch)
        engine = self.engine_for(mode)
        owner = who.id or None
        self._check_room(owner)
        self._starting[owner] += 1
        try:
            if owner is not None:
                await self._check_quota(owner, spec, nch)
            order = RunOrder(new_run_id(), spec, pace, mode, experiment, request, owner, private)
            record = await self._add(engine, order)
        finally:
            self._starting[owner] -= 1
        return await self.get(record.id)

    async def _add(self, engine: Engine, order: RunOrder) -> RunRecord:
        """Start ``order`` on ``engine``; its engine's ``started`` finds it here."""
        self._ordered[order.id] = order
        try:
            return await engine.add(order)
        finally:
            self._ordered.pop(order.id, None)

    async def _check_quota(self, owner: str, spec: RunSpec, nch: int) -> None:
        """The runs ``owner`` keeps, with this one, within the per-identity budgets (live
        runs count at their planned size)."""
        lim = self.limits
        used = await asyncio.to_thread(self.store.usage, owner)
        mine = [r for r in self._runs.values() if r.state.live and r.record.owner == owner]
        planned = sum(r.record.n_planned * len(r.record.channels) * 8 for r in mine)
        planned -= sum(r.next_k * len(r.record.channels) * 8 for r in mine)  # stored already
        Ts = spec.plant.Ts if spec.Ts is None else spec.Ts
        size = round(spec.duration / Ts) * nch * 8
        lim.check_kept(used.runs, used.bytes + planned, size)

    def _check_room(self, client: str | None) -> None:
        live = [r for r in self._runs.values() if r.state.live]
        mine = None
        if client is not None:
            mine = sum(r.record.owner == client for r in live) + self._starting[client]
        self.limits.check_live(len(live) + self._starting.total(), mine)

    async def control(self, run_id: str, action: Action, who: Identity) -> RunRecord:
        """Pause, resume or stop as ``who``: :class:`Forbidden` unless the owner or an
        instructor, :class:`Conflict` if the run cannot (it has ended)."""
        record = await self.get(run_id, who)
        require_control(who, record.owner, f"run {run_id}", action)
        await self._require_live(run_id)
        by = "its owner" if who.id == record.owner else who.name
        reason = {"pause": f"paused by {by}", "stop": f"stopped by {by}"}.get(action)
        await self._command(run_id, action, reason)
        run = self._runs.get(run_id)
        if run is not None:  # someone who may control it is there
            run.idle_paused, run.seen = False, time.monotonic()
            if action == "stop":
                await self._settle(run)  # answer with its end as stored
        return await self.get(run_id)

    async def _settle(self, run: LiveRun) -> None:
        """Until the end of a run its engine ended is decided (its samples stored), for at
        most ``END_WAIT`` s (a store that stalls longer: the answer says it is live yet)."""
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(run.settled.wait(), END_WAIT)

    async def delete(self, run_id: str, who: Identity) -> None:
        """Delete an ended run with its recording, as its owner or an instructor."""
        record = await self.get(run_id, who)
        require_control(who, record.owner, f"run {run_id}", "delete")
        run = self._runs.get(run_id)
        if run is not None and run.ending:
            await self._settle(run)
        if run is not None and run.state.live:
            raise Conflict(f"run {run_id} is {record.status}: stop it before deleting it")
        if run is not None:  # just ended: its last record is on its way to the store
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(run.forgotten.wait(), 10.0)
        self._channels.pop(run_id, None)
        await self._remove(run_id)

    @contextlib.contextmanager
    def downloading(self, run_id: str) -> Iterator[None]:
        """While a download of the run is under way: deleting the run then hides it at once
        and removes it when the last download has ended (a download never loses its end)."""
        self._downloads[run_id] += 1
        try:
            yield
        finally:
            self._downloads[run_id] -= 1
            if self._downloads[run_id] <= 0:
                del self._downloads[run_id]
                if run_id in self._deleted:
                    self._spawn(self._remove(run_id))

    async def _remove(self, run_id: str) -> bool:
        """Delete an ended run from the store, or later if it is being downloaded."""
        self._deleted.add(run_id)
        if self._downloads[run_id]:
            return False
        try:
            await asyncio.to_thread(self.store.delete_run, run_id)
        except NotFound:
            pass  # deleted meanwhile (a second request, the retention)
        finally:
            self._deleted.discard(run_id)
        return True

    async def _command(self, run_id: str, action: Action, reason: str | None) -> None:
        try:
            await self._engine_of(run_id).control(run_id, action, reason)
        except Conflict:
            run = self._runs.get(run_id)
            if run is not None and run.ending:
                await self._settle(run)
            if run is None or not run.state.live:  # it ended meanwhile
                record = await self.get(run_id)
                raise Conflict(
                    f"run {run_id} has ended ({record.status}): it cannot {action}"
                ) from None
            raise

    async def set_params(self, run_id: str, change: Change, who: Identity) -> Applied:
        """Apply the parts of ``change`` that alter what the run uses, from the next sample,
        as ``who`` (:func:`~elab.runs.changes.decide`); when none does, nothing is applied
        or recorded. :class:`Conflict` for a run that has ended."""
        record = await self.get(run_id, who)
        require_control(who, record.owner, f"run {run_id}", "change")
        run = self._runs.get(run_id)
        if run is None:
            raise _no_longer_steps(run_id, record.status)
        decision = decide(run.params, change)
        if decision.new is None:  # the same answer as a change: an ended run no longer steps
            if not run.state.live:
                raise _no_longer_steps(run_id, record.status)
            return Applied(record.n_stored)
        await self._require_live(run_id)
        k = await self._engine_of(run_id).replace(run_id, decision.new)
        run.params = run.params.after(decision.new)
        return Applied(k, decision.changed)

    async def _require_live(self, run_id: str) -> None:
        run = self._runs.get(run_id)
        if run is not None and run.ending:
            await self._settle(run)
        if run is None or not run.state.live:
            record = await self.get(run_id)  # NotFound for unknown ids
            raise _no_longer_steps(run_id, record.status)

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

    def _reader(self, run_id: str) -> Any:
        async def read(k0: int, k1: int) -> Array:
            return await self.read(run_id, k0, k1)

        return read

    # -- events from the engines (on the loop) ----------------------------------------
    def started(self, engine: str, record: RunRecord) -> None:
        names = tuple(n for n, _ in record.channels)
        ch = RunChannel(names, record.Ts, self._reader(record.id), self.codec, sender=self._sender)
        self._channels[record.id] = ch
        order = self._ordered[record.id]  # every run starts from this manager's order
        params = RunParams(order.spec.law, order.spec.reference)
        self._runs[record.id] = LiveRun(record, engine, ch, order, params)

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

    def params(self, engine: str, run_id: str, change: ParamChange) -> None:
        run = self._runs.get(run_id)
        if run is None:
            return
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
        run.stored = True
        if run.filling is None and run.settled.is_set():
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

    def _spawn(self, coro: Any) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
