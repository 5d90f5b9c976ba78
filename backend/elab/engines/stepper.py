"""The stepping thread: advances every live run of an engine, paced to the wall clock.

All live runs share one :class:`~elab.sim.batch.Batch`; each tick (20 ms, on a
fixed grid of the monotonic clock) the thread applies queued commands (add,
pause, resume, stop, parameter changes), steps each real-time run by the
samples due at the tick's scheduled time (sample ``k`` is due at
``t_origin + k Ts``, so the run's clock never drifts, and a late wake-up does
not change which samples a tick holds) and each fast run by a block, then hands
the new samples and the runs that ended to ``on_tick`` in one call.

A run whose controller is code (:mod:`elab.engines.coded`) gets a stepper of its own
(``lone``: its thread ends with the run; ``ordinary``: not real-time), in which it keeps a
slot of the batch (its place in the timetable) but is stepped by itself, sample by sample,
asking its sandboxed controller for each u, at most ``code_block`` samples a pass (so a
command waits for no more). A slow controller thus delays its own run only, never the
thread that steps everyone else's (issue 24: it stepped on the shared thread, and one
slow in 9 of 10 steps took a bystander from 1000 to 0-256 samples a second).

It is where every command on a run is decided: the run's state lives here, and
commands are applied one at a time in arrival order, so of two simultaneous
stops exactly one succeeds and the other gets :class:`~elab.errors.Conflict`, as
does any command for a run that has ended.
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Literal, TypeVar

import numpy as np
from numpy.typing import NDArray

from elab.engines.base import Block, Changed, Pace
from elab.engines.coded import CodedRun
from elab.engines.ticks import TickLog, ordinary_thread, realtime_thread
from elab.engines.timetable import Timetable
from elab.errors import Conflict
from elab.lifecycle import RunState, transition
from elab.sim.batch import Batch, SignalFault
from elab.sim.engine import diverged, first_divergence
from elab.sim.spec import DIVERGENCE_LIMIT, CompiledRun

log = logging.getLogger(__name__)

Array = NDArray[np.float64]
T = TypeVar("T")


@dataclass
class _Live:
    """A live run's state and spec; its counters are in the timetable, at its slot."""

    id: str
    run: CompiledRun
    pace: Pace
    slot: int
    state: RunState = RunState.RUNNING
    paused_at: float | None = None
    coded: CodedRun | None = None  # a code controller's run, stepped outside the batch


Command = Callable[[], None]
SLOW_TICK = 0.25  # a tick that took longer is logged with where its time went
Final = Literal[RunState.FINISHED, RunState.STOPPED, RunState.FAILED, RunState.INTERRUPTED]


class Stepper:
    """Owns the batch and the thread; every method is safe to call from any thread.

    ``on_tick(blocks, changes)`` is called in the thread with each tick's new samples and
    the state changes (pauses, resumes, ends) since the last call; ``backlog()`` true holds
    fast runs back (their samples would only pile up in front of a slow consumer)."""

    def __init__(
        self,
        on_tick: Callable[[list[Block], list[Changed]], None],
        *,
        tick: float = 0.02,
        fast_block: int = 1024,
        clock: Callable[[], float] = time.monotonic,
        backlog: Callable[[], bool] = lambda: False,
        realtime: int = 0,
        code_block: int = 64,
        lone: bool = False,
        ordinary: bool = False,
    ) -> None:
        self._on_tick = on_tick
        self._code_block = code_block
        self._lone = lone  # one run: the thread ends when it has ended
        self._ordinary = ordinary  # SCHED_OTHER, whatever the process's policy
        self._closed = False  # no more commands (a lone stepper whose run ended)
        self._accepting = threading.Lock()
        self.tick = tick
        self._fast_block = fast_block
        self._clock = clock
        self._backlog = backlog
        self.realtime = realtime  # SCHED_FIFO priority of the thread (0: ordinary)
        self._grid = clock()  # ticks fall on _grid + i · tick
        self._batch = Batch(capacity=16, block=max(fast_block, 1024))
        self._runs: dict[str, _Live] = {}
        self._table = Timetable()
        self._layouts: dict[tuple[int, ...], int] = {}  # column layout → its number
        self._columns: dict[int, NDArray[np.intp]] = {}  # and back, as an index array
        self._commands: queue.SimpleQueue[Command] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="elab-stepper", daemon=True)
        self.ticks = 0
        self.last_tick = clock()  # when the thread last began a tick (its watchdog reads it)
        self.tick_log = TickLog(tick)  # the last minute's ticks: how late each began

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)

    @property
    def live_count(self) -> int:
        return len(self._runs)

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    # -- commands (any thread) -------------------------------------------------
    def add(
        self,
        run_id: str,
        run: CompiledRun,
        pace: Pace,
        t_origin: float | None = None,
        coded: CodedRun | None = None,
    ) -> None:
        """Step ``run`` from the next tick; sample 0 is due at ``t_origin`` (on this stepper's
        clock; default: when the command is applied). ``coded``: its code controller,
        started; closed when the run ends."""
        self._put(lambda: self._add(run_id, run, pace, t_origin, coded))

    def control(self, run_id: str, action: str, reason: str | None = None) -> Future[int]:
        """Pause, resume or stop (``reason``: who and why, carried by the change); the sample
        index it happened at, or :class:`Conflict`."""
        target = {"pause": RunState.PAUSED, "resume": RunState.RUNNING, "stop": RunState.STOPPED}[
            action
        ]
        return self._call(lambda: self._control(run_id, target, reason))

    def replace(
        self, run_id: str, run: CompiledRun, *, controller: bool, signals: bool
    ) -> Future[int]:
        """``run`` from the next sample on: its controller (``controller``: the law changed;
        the controller state is kept) and its signals (``signals``: the reference changed);
        returns that sample's index."""
        return self._call(lambda: self._replace(run_id, run, controller, signals))

    def end(self, run_ids: list[str] | None, state: Final, reason: str) -> Future[list[str]]:
        """End the given live runs (``None``: all) in ``state`` with ``reason``; returns
        those that were still live."""
        return self._call(lambda: self._end_many(run_ids, state, reason))

    def _call(self, fn: Callable[[], T]) -> Future[T]:
        fut: Future[T] = Future()

        def command() -> None:
            try:
                fut.set_result(fn())
            except Exception as exc:  # handed to the caller through the future
                fut.set_exception(exc)

        if not self._put(command):
            fut.set_exception(Conflict("the run has ended: it no longer steps"))
        return fut

    def _put(self, command: Command) -> bool:
        with self._accepting:
            if not self._closed:
                self._commands.put(command)
            return not self._closed

    # -- in the thread ---------------------------------------------------------
    def _add(
        self,
        run_id: str,
        run: CompiledRun,
        pace: Pace,
        t_origin: float | None,
        coded: CodedRun | None,
    ) -> None:
        slot = self._batch.add(run)
        origin = self._clock() if t_origin is None else t_origin
        self._runs[run_id] = _Live(run_id, run, pace, slot, coded=coded)
        self._table.put(
            slot,
            run_id,
            origin=origin,
            Ts=run.Ts,
            end=run.n_samples,
            fast=pace == "fast",
            layout=0,
            coded=coded is not None,
        )
        self._refresh_columns()

    def _k(self, live: _Live) -> int:
        return int(self._table.k[live.slot])

    def _live(self, run_id: str) -> _Live:
        live = self._runs.get(run_id)
        if live is None:
            raise Conflict(f"run {run_id} has ended: it no longer steps")
        return live

    def _control(self, run_id: str, target: RunState, reason: str | None) -> int:
        live = self._live(run_id)
        transition(live.state, target)  # Conflict if not allowed
        if target is RunState.STOPPED:
            ended = self._end(live, RunState.STOPPED, reason)
            self._on_tick([], [ended])
            return ended.k
        if target is RunState.PAUSED:
            live.paused_at = self._clock()
        else:  # the clock stops for whole ticks: frames stay aligned
            assert live.paused_at is not None
            paused = self._clock() - live.paused_at
            self._table.origin[live.slot] += math.ceil(paused / self.tick - 1e-9) * self.tick
            live.paused_at = None
        self._table.paused[live.slot] = target is RunState.PAUSED
        live.state = target
        self._on_tick([], [Changed(run_id, target, self._k(live), reason)])
        return self._k(live)

    def _replace(self, run_id: str, run: CompiledRun, controller: bool, signals: bool) -> int:
        live = self._live(run_id)
        if live.coded is not None:  # its law never changes (the engine refuses that)
            assert not controller, "a code controller is not swapped mid-run"
            live.coded.set_run(run)
            live.run = run
            return self._k(live)
        if controller:
            self._batch.set_controller(live.slot, run)
        if signals or not controller:  # both may change at once: each must take effect
            self._batch.set_run(live.slot, run)
        live.run = run
        return self._k(live)

    def _end_many(self, run_ids: list[str] | None, state: Final, reason: str) -> list[str]:
        lives = (
            list(self._runs.values())
            if run_ids is None
            else [self._runs[i] for i in run_ids if i in self._runs]
        )
        if lives:
            self._on_tick([], [self._end(live, state, reason) for live in lives])
        return [live.id for live in lives]

    def _refresh_columns(self) -> None:
        """Each run's columns [r, u, y…, x…] in the batch's block (they move when a run
        with more outputs or states joins), numbered by layout."""
        for live in self._runs.values():
            ys, xs = self._batch.columns(live.slot)
            cols = (0, 1, *range(ys.start, ys.stop), *range(xs.start, xs.stop))
            layout = self._layouts.get(cols)
            if layout is None:  # a new layout (its index array made once)
                layout = self._layouts[cols] = len(self._layouts)
                self._columns[layout] = np.array(cols, dtype=np.intp)
            self._table.layout[live.slot] = layout

    def _commands_now(self) -> None:
        while True:
            try:
                command = self._commands.get_nowait()
            except queue.Empty:
                return
            try:
                command()
            except Exception:  # a failed add: the run never starts; the others go on
                log.exception("stepper command failed")

    def _loop(self) -> None:
        if self.realtime:
            self.realtime = realtime_thread(self.realtime)
        if self._ordinary:
            ordinary_thread()
        deadline = self.align(self._clock())
        while not self._stop.is_set():
            began = self._clock()
            self._commands_now()
            if self._lone and self.ticks and not self._runs:
                with self._accepting:  # its run has ended: answer what came, then stop
                    self._closed = True
                self._commands_now()
                return
            now = self._clock()
            self.ticks += 1
            self.last_tick = now
            try:  # the tick's scheduled time, unless it is early (the first pass, fast runs)
                blocks, ended = self._step(min(now, deadline))
            except Exception as exc:  # a bug must not stop the thread and hang every run
                log.exception("stepping failed; ending the live runs")
                blocks, ended = (
                    [],
                    [
                        self._end(live, RunState.FAILED, f"internal error: {exc!r}")
                        for live in list(self._runs.values())
                    ],
                )
            on_time = now >= deadline  # a tick; else an early pass (the first, fast runs)
            if on_time:  # only ticks count in the timing: early passes are never late
                self.tick_log.add(deadline, now - deadline, self._table.clock_lag(now))
            stepped = self._clock()
            if blocks or ended:
                self._on_tick(blocks, ended)
            done = self._clock()
            if done - began > SLOW_TICK:
                log.warning(
                    "a tick took %.2f s (commands %.2f s, stepping %.2f s for %d runs, "
                    "recording %.2f s for %d samples)",
                    done - began,
                    now - began,
                    stepped - now,
                    len(self._runs),
                    done - stepped,
                    sum(b.data.shape[0] * b.data.shape[1] for b in blocks),
                )
            fast = self._table.fast_due()
            if on_time:  # the next tick, on the grid (an early pass leaves it where it is:
                # each once moved it on by a tick, and after a long fast run the thread
                # slept seconds while the real-time runs stood still)
                deadline = self.align(max(deadline + self.tick, self._clock()))
            time.sleep(0.0005 if fast else max(0.0, deadline - self._clock()))

    def timing(self) -> dict[str, float | int]:
        """How closely the ticks of the last minute kept to their schedule
        (:meth:`TickLog.timing`)."""
        return self.tick_log.timing(self.ticks)

    def align(self, t: float) -> float:
        """The first tick at or after ``t``."""
        return self._grid + math.ceil((t - self._grid) / self.tick - 1e-9) * self.tick

    def origin(self, t: float, Ts: float) -> float:
        """When sample 0 of a real-time run starting at ``t`` is due: one sample after the
        next tick. Sample ``k`` is then due at a tick when ``k + 1`` is a multiple of
        ``tick / Ts``; a run whose frames last one tick (20 samples at 1 kHz) gets exactly
        one frame per tick, sent at the tick its last sample is due."""
        return self.align(t) + Ts

    def _step(self, now: float) -> tuple[list[Block], list[Changed]]:
        table = self._table
        fast = 0 if table.fast.any() and self._backlog() else self._fast_block
        due = table.due(now, fast, self._batch.block)
        blocks: list[Block] = []
        ended: list[Changed] = []
        coded = np.flatnonzero(table.coded & (due > 0))
        if coded.size:  # stepped by themselves, after the batch
            code_due = np.minimum(due, self._code_block)[coded]
            due[coded] = 0
        stepped = np.flatnonzero(due)
        for n in np.unique(due[stepped]).tolist():
            slots, block = self._advance(n, stepped[due[stepped] == n], ended)
            if not slots.size:
                continue
            # runs with the same columns (the same plant) are cut out of the block with
            # one copy and checked for divergence at once
            for layout in np.unique(table.layout[slots]).tolist():
                group = slots[table.layout[slots] == layout]
                data = block[np.ix_(group, np.arange(n), self._columns[layout])]
                with np.errstate(invalid="ignore"):
                    fine = (np.abs(data[:, :, 1:]) <= DIVERGENCE_LIMIT).all(axis=(1, 2))
                if not fine.all():
                    for i in np.flatnonzero(~fine).tolist():
                        blocks.append(self._record(self._runs[table.ids[group[i]]], data[i], ended))
                    group, data = group[fine], data[fine]
                if group.size:
                    blocks.append(Block(table.ids[group].tolist(), table.k[group].tolist(), data))
                    table.k[group] += n
        if coded.size:
            for slot, n in zip(coded.tolist(), code_due.tolist(), strict=True):
                own = self._step_coded(self._runs[table.ids[slot]], n, ended)
                if own is not None:
                    blocks.append(own)
        for slot in table.finished().tolist():
            ended.append(self._end(self._runs[table.ids[slot]], RunState.FINISHED))
        return blocks, ended

    def _advance(
        self, n: int, slots: NDArray[np.intp], ended: list[Changed]
    ) -> tuple[NDArray[np.intp], Array]:
        """Step ``slots`` by ``n`` samples; a run whose signals cannot be computed fails
        alone (once, a PRBS held 10³⁰⁰ samples failed every live run of the engine)."""
        while True:
            try:
                return slots, self._batch.advance(n, slots.tolist())
            except SignalFault as fault:
                log.warning("a run's signals failed", exc_info=fault.__cause__)
                live = self._runs[self._table.ids[fault.slot]]
                ended.append(self._end(live, RunState.FAILED, f"{fault}: {fault.__cause__!r}"))
                slots = slots[slots != fault.slot]
                if not slots.size:
                    return slots, np.empty((0, n, 0))

    def _record(self, live: _Live, data: Array, ended: list[Changed]) -> Block:
        """The samples of a run whose block failed the divergence check: those before it
        diverged (and the run fails), or all (a false alarm)."""
        i = first_divergence(data[:, 1:])  # u, y, x
        k0 = self._k(live)
        block = Block([live.id], [k0], (data if i is None else data[:i])[np.newaxis])
        self._table.k[live.slot] += data.shape[0] if i is None else i
        if i is not None:
            ended.append(self._end(live, RunState.FAILED, diverged((k0 + i) * live.run.Ts)))
        return block

    def _step_coded(self, live: _Live, n: int, ended: list[Changed]) -> Block | None:
        """``n`` samples of a code-controller run: those before its controller failed or
        the loop diverged, and then the run fails."""
        assert live.coded is not None
        data, failed = live.coded.advance(n)
        i = first_divergence(data[:, 1:])
        k0 = self._k(live)
        if i is not None:
            data = data[:i]
            failed = diverged((k0 + i) * live.run.Ts)
        self._table.k[live.slot] += data.shape[0]
        if failed is not None:
            ended.append(self._end(live, RunState.FAILED, failed))
        return Block([live.id], [k0], data[np.newaxis]) if data.shape[0] else None

    def _end(self, live: _Live, state: Final, error: str | None = None) -> Changed:
        transition(live.state, state)
        k = self._k(live)
        del self._runs[live.id]
        self._batch.remove(live.slot)
        self._table.clear(live.slot)
        compute = None
        if live.coded is not None:  # its controller's process ends with it
            compute = live.coded.times()
            live.coded.close()
        return Changed(live.id, state, k, error, compute)
