"""Run lifecycle: create, step, record, fan out, pause, resume, stop, change live.

The manager lives on the event loop. The stepping thread hands it each tick's
samples: they go to the recorder at once (in that thread), then to the run's
channel on the loop. Every parameter change is applied by the stepper between
two samples and stored with that sample's index.
"""

from __future__ import annotations

import asyncio
import secrets
import time
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from elab.errors import Conflict, InvalidInput, TooMany
from elab.laws import ControlLaw
from elab.runs.fanout import RunChannel, Sender, pack, publish_block
from elab.runs.recorder import Recorder
from elab.runs.state import RunState, transition
from elab.runs.stepper import Block, Ended, Pace, Stepper
from elab.runs.store import ParamChange, RunRecord, Store
from elab.sim.result import Samples
from elab.sim.signals import Signal
from elab.sim.spec import CompiledRun, RunSpec, compile_run

Array = NDArray[np.float64]


@dataclass
class _Live:
    record: RunRecord
    run: CompiledRun
    state: RunState
    k: int = 0  # samples published
    ended: asyncio.Event = field(default_factory=asyncio.Event)


def channels_of(run: CompiledRun) -> tuple[tuple[str, str], ...]:
    """Recorded columns ``r, u, y…, x…`` with units (the time column is derived)."""
    empty = Samples(run.spec.plant, run.Ts, 0, np.zeros(0), np.zeros(0),
                    np.zeros((0, run.spec.plant.ny)), np.zeros((0, run.spec.plant.nx)))
    return tuple((c.name, c.unit) for c, _ in empty.channels()[1:])


class RunManager:
    """All runs of one server process."""

    def __init__(self, store: Store, *, max_live: int = 400, max_duration: float = 3600.0,
                 tick: float = 0.02, flush_interval: float = 0.25) -> None:
        self.store = store
        self.max_live = max_live
        self.max_duration = max_duration
        self.recorder = Recorder(store, flush_interval)
        self.stepper = Stepper(self._on_tick, tick=tick)
        self._live: dict[str, _Live] = {}
        self._channels: dict[str, RunChannel] = {}
        self._sender = Sender()  # one pass over all watchers per tick
        self._loop: asyncio.AbstractEventLoop | None = None
        self.interrupted: list[str] = []
        self._tasks: set[asyncio.Future[None]] = set()

    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self.interrupted = await asyncio.to_thread(self.store.mark_interrupted)
        self.recorder.start()
        self.stepper.start()

    async def close(self) -> None:
        """Stop stepping; runs cut short are stored as interrupted."""
        self.stepper.close()
        await asyncio.to_thread(self.recorder.close)
        for live in list(self._live.values()):
            await self._set_state(live, RunState.INTERRUPTED, error="server shut down")
        self._live.clear()

    # -- queries ---------------------------------------------------------------
    @property
    def live_count(self) -> int:
        return len(self._live)

    def status(self) -> dict[str, Any]:
        """Live runs, connected watchers and the stepping thread's timing."""
        return {"live_runs": len(self._live),
                "watchers": sum(len(ch.watchers) for ch in self._channels.values()),
                "stepper": self.stepper.timing()}

    async def get(self, run_id: str) -> RunRecord:
        live = self._live.get(run_id)
        if live is not None:
            return replace(live.record, status=live.state.value, n_stored=live.k)
        return await asyncio.to_thread(self.store.get_run, run_id)

    async def read(self, run_id: str, k0: int = 0, k1: int | None = None) -> Array:
        record = await self.get(run_id)
        end = record.n_stored if k1 is None else min(k1, record.n_stored)
        return await asyncio.to_thread(self.recorder.read, run_id, k0, end)

    # -- lifecycle ---------------------------------------------------------------
    async def create(self, spec: RunSpec, *, pace: Pace, mode: str, experiment: str,
                     request: dict[str, Any]) -> RunRecord:
        if len(self._live) >= self.max_live:
            raise TooMany(f"{len(self._live)} runs are live, the limit of this server "
                          f"(ELAB_MAX_LIVE_RUNS = {self.max_live}); wait for one to end")
        if spec.duration > self.max_duration:
            raise InvalidInput("duration", spec.duration,
                               f"a duration in (0, {self.max_duration:g}] s")
        run = compile_run(spec)
        # sample 0 just after the stepper's next tick, so each tick completes a frame;
        # started_at: the wall time of sample 0
        mono = time.monotonic()
        origin = self.stepper.origin(mono, run.Ts) if pace == "realtime" else mono
        now = time.time() + (origin - mono)
        record = RunRecord(id=f"r-{secrets.token_hex(6)}", plant=spec.plant.id, mode=mode,
                           experiment=experiment, spec=request, status=RunState.RUNNING.value,
                           Ts=run.Ts, channels=channels_of(run), n_planned=run.n_samples,
                           created_at=now, started_at=now)
        await asyncio.to_thread(self.store.create_run, record)
        self.recorder.open(record.id, len(record.channels))
        self._live[record.id] = _Live(record, run, RunState.RUNNING)
        self._channels[record.id] = RunChannel(
            tuple(name for name, _ in record.channels), run.Ts, self._reader(record.id),
            sender=self._sender)
        self.stepper.add(record.id, run, pace, t_origin=origin)
        return record

    async def pause(self, run_id: str) -> RunRecord:
        live = self._require_live(run_id, RunState.PAUSED)
        await asyncio.wrap_future(self.stepper.pause(run_id))
        await self._set_state(live, RunState.PAUSED)
        return await self.get(run_id)

    async def resume(self, run_id: str) -> RunRecord:
        live = self._require_live(run_id, RunState.RUNNING)
        await asyncio.wrap_future(self.stepper.resume(run_id))
        await self._set_state(live, RunState.RUNNING)
        return await self.get(run_id)

    async def stop(self, run_id: str) -> RunRecord:
        live = self._require_live(run_id, RunState.STOPPED)
        await asyncio.wrap_future(self.stepper.stop(run_id))
        await live.ended.wait()  # the stepper reports the end through the loop
        return await self.get(run_id)

    async def set_params(self, run_id: str, *, law: ControlLaw | None, reference: Signal | None,
                         params: dict[str, Any]) -> int:
        """Apply a new law and/or reference from the next sample; returns that sample."""
        live = self._require_live(run_id, None)
        spec = live.run.spec
        new = compile_run(replace(spec, law=law or spec.law, reference=reference or spec.reference))
        if law is not None and new.controller.nc != live.run.controller.nc:
            raise InvalidInput("controller", params.get("controller"),
                               f"a {type(spec.law).__name__} law like the run's (its controller "
                               "state size cannot change mid-run); start a new run instead")
        k = await asyncio.wrap_future(self.stepper.replace(run_id, new, controller=law is not None))
        live.run = new
        change = ParamChange(k=k, params=params, at=time.time())
        await asyncio.to_thread(self.store.add_param_change, run_id, change)
        self._channels[run_id].control(pack({"type": "params", "k": k, "t": k * new.Ts,
                                             "params": params}))
        return k

    def channel(self, record: RunRecord) -> RunChannel:
        """The live channel of a run, or a replay channel over its recording."""
        ch = self._channels.get(record.id)
        if ch is None:
            ch = RunChannel(tuple(n for n, _ in record.channels), record.Ts,
                            self._reader(record.id), edge=record.n_stored, ended=True,
                            sender=self._sender)
            self._channels[record.id] = ch
        return ch

    def release(self, run_id: str, channel: RunChannel) -> None:
        """Forget a finished run's channel once nobody watches it."""
        if not channel.watchers and run_id not in self._live:
            self._channels.pop(run_id, None)

    # -- internals ---------------------------------------------------------------
    def _reader(self, run_id: str) -> Any:
        async def read(k0: int, k1: int) -> Array:
            return await asyncio.to_thread(self.recorder.read, run_id, k0, k1)
        return read

    def _require_live(self, run_id: str, target: RunState | None) -> _Live:
        live = self._live.get(run_id)
        if live is None:
            record = self.store.get_run(run_id)  # NotFound for unknown ids
            raise Conflict(f"run {run_id} is {record.status}: it no longer steps")
        if target is not None:
            transition(live.state, target)
        return live

    def _on_tick(self, blocks: list[Block], ended: list[Ended]) -> None:
        """In the stepping thread: record now, publish on the loop."""
        for b in blocks:
            self.recorder.append_many(b.run_ids, b.k0, b.data)
        if self._loop is not None:
            self._loop.call_soon_threadsafe(self._publish, blocks, ended)

    def _publish(self, blocks: list[Block], ended: list[Ended]) -> None:
        for b in blocks:
            n = b.data.shape[1]
            channels: list[RunChannel | None] = []
            for run_id, k0 in zip(b.run_ids, b.k0, strict=True):
                live = self._live.get(run_id)
                if live is not None:
                    live.k = k0 + n
                channels.append(None if live is None else self._channels[run_id])
            publish_block(channels, b.data)
        for e in ended:
            live = self._live.get(e.run_id)
            if live is not None:
                task = asyncio.ensure_future(self._finish(live, e))
                self._tasks.add(task)
                task.add_done_callback(self._tasks.discard)

    async def _finish(self, live: _Live, e: Ended) -> None:
        await asyncio.to_thread(self.recorder.finish, e.run_id)
        state = {"finished": RunState.FINISHED, "stopped": RunState.STOPPED,
                 "failed": RunState.FAILED}[e.state]
        await self._set_state(live, state, error=e.error, end=True)
        self._live.pop(e.run_id, None)
        live.ended.set()
        ch = self._channels.get(e.run_id)
        if ch is not None:
            self.release(e.run_id, ch)

    async def _set_state(self, live: _Live, state: RunState, *, error: str | None = None,
                         end: bool = False) -> None:
        live.state = transition(live.state, state)
        finished_at = time.time() if not state.live else None
        await asyncio.to_thread(self.store.set_status, live.record.id, state.value,
                                finished_at=finished_at, error=error)
        status = _status(live, error)
        ch = self._channels.get(live.record.id)
        if ch is not None:
            ch.end(status) if end else ch.control(status)


def _status(live: _Live, error: str | None) -> bytes:
    msg: dict[str, Any] = {"type": "status", "state": live.state.value, "k": live.k}
    if error:
        msg["error"] = error
    return pack(msg)


def status_message(record: RunRecord) -> dict[str, Any]:
    return {"type": "status", "state": record.status, "k": record.n_stored,
            **({"error": record.error} if record.error else {})}


Stream = Literal["live", "replay"]
