"""Runs nobody watches and runs past their retention: a real-time run whose owner has no
connection to it pauses, then stops (:meth:`Limits.unwatched` says when and why); ended
runs older than the retention are deleted."""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Awaitable, Callable, Coroutine
from dataclasses import dataclass, field
from typing import Any, Protocol

from elab.engines.base import Action
from elab.errors import ElabError
from elab.lifecycle import RunState
from elab.runs.limits import Limits
from elab.runs.live import LiveRun
from elab.store.base import RunStore

log = logging.getLogger(__name__)


class SharedPresence(Protocol):
    """When the web processes last saw each run's owner, shared among them (several web
    processes on a broker: the owner may watch through any of them)."""

    async def exchange(self, seen: dict[str, float]) -> dict[str, float]:
        """Say when this process saw owners (unix s, by run); the latest any process saw
        each run's owner, of the runs in ``seen``."""


@dataclass(eq=False)
class Patrol:
    """Looks after the runs a manager follows (``runs``, shared with it): ``command``
    pauses or stops one, ``remove`` deletes an ended one (false while it is downloaded);
    ``presence``: owners seen by other web processes count too."""

    runs: dict[str, LiveRun]
    limits: Limits
    store: RunStore
    command: Callable[[str, Action, str], Awaitable[None]]
    remove: Callable[[str], Awaitable[bool]]
    presence: SharedPresence | None = None
    _tasks: set[asyncio.Task[None]] = field(default_factory=set)

    async def run(self) -> None:
        """Every second: pause and then stop real-time runs whose owner is gone; every
        ten minutes (a quarter of the retention if shorter), delete runs past the
        retention."""
        sweep_at = 0.0
        while True:
            await asyncio.sleep(min(1.0, self.limits.owner_grace / 4))
            if self.presence is not None:
                await self._share()
            now = time.monotonic()
            for run in list(self.runs.values()):
                self._look_after(run, now)
            if self.limits.retention > 0 and now >= sweep_at:
                sweep_at = now + min(600.0, max(1.0, self.limits.retention / 4))
                self._spawn(self._sweep())

    async def _share(self) -> None:
        """Owners seen here, out; seen anywhere, in (a run's ``seen`` the latest of all)."""
        assert self.presence is not None
        live = [r for r in self.runs.values() if r.state.live and math.isfinite(r.seen)]
        if not live:
            return
        lag = time.time() - time.monotonic()  # monotonic -> unix s
        try:
            seen = await self.presence.exchange({r.record.id: r.seen + lag for r in live})
        except ElabError as exc:  # judged by this process's own sightings meanwhile
            log.warning("owners' presence not shared this round: %s", exc)
            return
        for run in live:
            at = seen.get(run.record.id)
            if at is not None and math.isfinite(run.seen):
                run.seen = max(run.seen, at - lag)

    def _look_after(self, run: LiveRun, now: float) -> None:
        owner = run.record.owner
        if not run.state.live or run.ending or run.order.pace == "fast":
            return
        if owner and any(w.who == owner for w in run.channel.watchers):
            run.seen = now
            return
        running = run.state is RunState.RUNNING and not run.idle_paused
        match self.limits.unwatched(now - run.seen, running):
            case ("stop", reason):
                run.seen = math.inf  # once
                self._spawn(self._quietly(run.record.id, "stop", reason))
            case ("pause", reason):
                run.idle_paused = True
                self._spawn(self._quietly(run.record.id, "pause", reason))
            case None:
                pass

    async def _quietly(self, run_id: str, action: Action, reason: str) -> None:
        try:
            await self.command(run_id, action, reason)
        except ElabError as exc:  # it ended meanwhile, or the engine is down: next round
            log.info("run %s: %s not done: %s", run_id, action, exc)
            run = self.runs.get(run_id)
            if run is not None and run.seen == math.inf:
                run.seen = time.monotonic() - self.limits.owner_gone + 5.0

    async def _sweep(self) -> None:
        cutoff = time.time() - self.limits.retention
        try:
            while ids := await asyncio.to_thread(self.store.ended_before, cutoff):
                done = [run_id for run_id in ids if await self.remove(run_id)]
                log.info("deleted %d runs past the retention", len(done))
                if not done:  # all being downloaded: they go when their downloads end
                    break
        except ElabError:
            log.exception("deleting runs past the retention failed; tried again later")

    def _spawn(self, coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
