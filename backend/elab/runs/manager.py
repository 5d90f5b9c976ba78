"""Runs on the web side: start them on an engine, command and ask about them.

The manager lives on the event loop. It starts a run on the engine of its mode
(:class:`Engines`: simulation, rig) after checking it against the limits, and sends
every later command to the engine that steps it, as recorded with the run (the engine
decides them, records everything and answers), once :mod:`elab.access` allows it. What
the engines report, and the runs and recordings it keeps, are
:class:`~elab.runs.follow.RunFollower`'s.
"""

from __future__ import annotations

import asyncio
import contextlib
import secrets
import time
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

from elab.access import Identity, may_view, require_control
from elab.engines.base import Action, Engine, EngineStatus, Pace, RunOrder
from elab.errors import Conflict, InvalidInput, NotFound, Unavailable
from elab.runs.changes import Applied, Change, decide
from elab.runs.fanout import Codec
from elab.runs.follow import RunFollower
from elab.runs.limits import Limits
from elab.runs.live import LiveRun
from elab.runs.patrol import Patrol, SharedPresence
from elab.runs.rigdesk import RigDesk
from elab.sim.spec import RunSpec
from elab.store.base import JsonObject, ParamChange, RunRecord, RunStore, RunSummary

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
    #: each engine process stepping simulations (one; or each engine on a broker)
    simulation_engines: list[EngineStatus] = field(default_factory=list)
    #: how far the most belated watcher is behind its run's stream (s); how many are
    #: catching up from the recording (they fell behind, or joined late) and how many are
    #: having frames skipped (too slow for their queue; told so when they read again)
    delivery_lag_max: float = 0.0
    catching_up: int = 0
    skipping: int = 0


class RunManager(RunFollower):
    """All runs as this web process sees them: commands and questions about them, checked
    (who may, the limits) and sent to the engine that steps the run; what the engines
    report is followed by :class:`RunFollower`."""

    def __init__(
        self,
        store: RunStore,
        engines: Engines,
        codec: Codec,
        *,
        limits: Limits | None = None,
        desk: RigDesk | None = None,
        presence: SharedPresence | None = None,
    ) -> None:
        if "simulation" not in engines:
            raise ValueError("a run manager needs a simulation engine")
        super().__init__(store, codec)
        self.engines = dict(engines)
        self._by_id = {e.id: e for e in engines.values()}
        self.limits = limits or Limits()
        self.desk = desk  # the rig's queue (a server with a rig)
        self.presence = presence  # owners seen by the other web processes (on a broker)
        self._starting: Counter[str | None] = Counter()  # runs being started, by owner
        self._downloads: Counter[str] = Counter()  # downloads under way, by run
        self._deleted: set[str] = set()  # deleted while downloaded: removed after the last
        self._patrol_task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        for engine in self.engines.values():
            await engine.start(self)
        patrol = Patrol(
            self._runs, self.limits, self.store, self._command, self._remove, self.presence
        )
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
        watching = [(ch, w) for ch in self._channels.values() for w in ch.watchers]
        return ManagerStatus(
            live_runs=self.live_count,
            watchers=len(watching),
            engines={mode: e.status() for mode, e in self.engines.items()},
            simulation_engines=self.engines["simulation"].statuses(),
            delivery_lag_max=max((ch.lag(w) for ch, w in watching), default=0.0),
            catching_up=sum(w.pull_from is not None for _, w in watching),
            skipping=sum(w.skipped is not None for _, w in watching),
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
        # an engine of its own id, or the engines of its mode on a broker (which know
        # which of them steps it)
        engine = self._by_id.get(run.engine) or self.engines.get(run.record.mode)
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
            if mode == "rig" and self.desk is not None:  # the rig's queue seats it first
                record = await self.desk.seated(who, order, lambda: self._add(engine, order))
            else:
                record = await self._add(engine, order)
        finally:
            self._starting[owner] -= 1
        return await self.get(record.id)

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
            await self._ended_meanwhile(run_id, action)
            raise

    async def _ended_meanwhile(self, run_id: str, what: str) -> None:
        """After the engine refused a command: if the run ended meanwhile, wait until its
        end is stored (so the run's record says so when the answer does) and refuse with
        its status."""
        run = self._runs.get(run_id)
        if run is not None and run.ending:
            await self._settle(run)
        if run is None or not run.state.live:
            record = await self.get(run_id)
            raise Conflict(f"run {run_id} has ended ({record.status}): it cannot {what}")

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
        try:
            k = await self._engine_of(run_id).replace(run_id, decision.new)
        except Conflict:  # it ended after the check: answered as its record will say
            await self._ended_meanwhile(run_id, "change")
            raise
        run.params = run.params.after(decision.new)
        return Applied(k, decision.changed)

    async def _require_live(self, run_id: str) -> None:
        run = self._runs.get(run_id)
        if run is not None and run.ending:
            await self._settle(run)
        if run is None or not run.state.live:
            record = await self.get(run_id)  # NotFound for unknown ids
            raise _no_longer_steps(run_id, record.status)
