"""The stepping thread: advances every live run, paced to the wall clock.

All live runs share one :class:`~elab.sim.batch.Batch`; each tick (20 ms, on a
fixed grid of the monotonic clock) the thread applies queued commands (add,
pause, resume, stop, parameter changes), steps each real-time run by the
samples due at the tick's scheduled time (sample ``k`` is due at
``t_origin + k Ts``, so the run's clock never drifts, and a late wake-up does
not change which samples a tick holds) and each fast run by a block, then hands
the new samples to ``on_tick`` in one call. The compiled loop
releases the GIL, so stepping does not stall the web event loop.
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
import scipy.stats
from numpy.typing import NDArray

from elab.sim.batch import Batch
from elab.sim.engine import DIVERGENCE_LIMIT, first_divergence
from elab.sim.spec import CompiledRun

log = logging.getLogger(__name__)

Array = NDArray[np.float64]
Pace = Literal["realtime", "fast"]


class Block(NamedTuple):
    """New samples of runs stepped together (one per plant and tick, not one per run: at
    300 runs the per-run objects and copies were a sixth of the server's CPU): run
    ``run_ids[i]`` has rows ``k0[i] .. k0[i]+n-1`` in ``data[i]`` (runs × n × columns)."""

    run_ids: list[str]
    k0: list[int]
    data: Array


@dataclass(frozen=True)
class Ended:
    """A run left the stepper: ``finished`` (all samples), ``stopped`` or ``failed``."""

    run_id: str
    state: Literal["finished", "stopped", "failed"]
    k: int
    error: str | None = None


@dataclass
class _Live:
    id: str
    run: CompiledRun
    pace: Pace
    slot: int
    t_origin: float
    k: int = 0
    paused_at: float | None = None
    cols: tuple[int, ...] = ()  # its columns [r, u, y…, x…] in the batch's block


Command = Callable[[], None]


class Stepper:
    """Owns the batch and the thread; every method is safe to call from any thread."""

    def __init__(self, on_tick: Callable[[list[Block], list[Ended]], None], *,
                 tick: float = 0.02, fast_block: int = 1024,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._on_tick = on_tick
        self.tick = tick
        self._fast_block = fast_block
        self._clock = clock
        self._grid = clock()  # ticks fall on _grid + i · tick
        self._batch = Batch(capacity=16, block=max(fast_block, 1024))
        self._runs: dict[str, _Live] = {}
        self._commands: queue.SimpleQueue[Command] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="elab-stepper", daemon=True)
        self.ticks = 0
        # (scheduled time, how late the tick began) of the last minute's ticks
        self._late: deque[tuple[float, float]] = deque(maxlen=round(60.0 / tick))

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)

    # -- commands (any thread) -------------------------------------------------
    def add(self, run_id: str, run: CompiledRun, pace: Pace, t_origin: float | None = None) -> None:
        """Step ``run`` from the next tick; sample 0 is due at ``t_origin`` (on this stepper's
        clock; default: when the command is applied)."""
        self._commands.put(lambda: self._add(run_id, run, pace, t_origin))

    def pause(self, run_id: str) -> Future[int]:
        return self._call(lambda: self._pause(run_id))

    def resume(self, run_id: str) -> Future[int]:
        return self._call(lambda: self._resume(run_id))

    def stop(self, run_id: str) -> Future[int]:
        return self._call(lambda: self._stop_run(run_id))

    def replace(self, run_id: str, run: CompiledRun, *, controller: bool) -> Future[int]:
        """New spec from the next sample on; returns that sample's index."""
        return self._call(lambda: self._replace(run_id, run, controller))

    def _call(self, fn: Callable[[], int]) -> Future[int]:
        fut: Future[int] = Future()

        def command() -> None:
            try:
                fut.set_result(fn())
            except Exception as exc:  # handed to the caller through the future
                fut.set_exception(exc)

        self._commands.put(command)
        return fut

    # -- in the thread ---------------------------------------------------------
    def _add(self, run_id: str, run: CompiledRun, pace: Pace, t_origin: float | None) -> None:
        slot = self._batch.add(run)
        origin = self._clock() if t_origin is None else t_origin
        self._runs[run_id] = _Live(run_id, run, pace, slot, origin)
        self._refresh_columns()

    def _pause(self, run_id: str) -> int:
        live = self._runs[run_id]
        if live.paused_at is None:
            live.paused_at = self._clock()
        return live.k

    def _resume(self, run_id: str) -> int:
        live = self._runs[run_id]
        if live.paused_at is not None:  # the clock stops for whole ticks: frames stay aligned
            paused = self._clock() - live.paused_at
            live.t_origin += math.ceil(paused / self.tick - 1e-9) * self.tick
            live.paused_at = None
        return live.k

    def _stop_run(self, run_id: str) -> int:
        ended = self._end(self._runs[run_id], "stopped")
        self._on_tick([], [ended])
        return ended.k

    def _replace(self, run_id: str, run: CompiledRun, controller: bool) -> int:
        live = self._runs[run_id]
        if controller:
            self._batch.set_controller(live.slot, run)
        else:
            self._batch.set_run(live.slot, run)
        live.run = run
        return live.k

    def _refresh_columns(self) -> None:
        for live in self._runs.values():
            ys, xs = self._batch.columns(live.slot)
            live.cols = (0, 1, *range(ys.start, ys.stop), *range(xs.start, xs.stop))

    def _loop(self) -> None:
        deadline = self.align(self._clock())
        while not self._stop.is_set():
            while True:
                try:
                    command = self._commands.get_nowait()
                except queue.Empty:
                    break
                try:
                    command()
                except Exception:  # a failed add: the run never starts; the others go on
                    log.exception("stepper command failed")
            now = self._clock()
            self.ticks += 1
            self._late.append((deadline, max(0.0, now - deadline)))
            try:  # the tick's scheduled time, unless it is early (the first pass, fast runs)
                blocks, ended = self._step(min(now, deadline))
            except Exception as exc:  # a bug must not stop the thread and hang every run
                log.exception("stepping failed; ending the live runs")
                blocks, ended = [], [self._end(live, "failed", f"internal error: {exc!r}")
                                     for live in list(self._runs.values())]
            if blocks or ended:
                self._on_tick(blocks, ended)
            fast = any(r.pace == "fast" and r.paused_at is None for r in self._runs.values())
            deadline = self.align(max(deadline + self.tick, self._clock()))  # stay on the grid
            time.sleep(0.0005 if fast else max(0.0, deadline - self._clock()))

    def timing(self) -> dict[str, float | int]:
        """How closely the ticks of the last minute kept to their schedule: how late they
        began (ms; p50, p99, max) and the trend of that lateness (ms per minute): the
        Theil–Sen slope of its medians over 12 equal parts of the minute, which one long
        stall does not tilt. A real-time sample is computed at the first tick at or after
        its due time, so this trend is the drift of the runs' clocks against the monotonic
        clock."""
        late = np.array(self._late.copy())  # deque.copy is atomic; the thread appends
        out: dict[str, float | int] = {"ticks": self.ticks, "tick_s": self.tick,
                                       "window_s": 0.0, "late_p50_ms": 0.0, "late_p99_ms": 0.0,
                                       "late_max_ms": 0.0, "drift_ms_per_min": 0.0}
        if late.shape[0] >= 2:
            t, lag = late[:, 0], late[:, 1] * 1e3
            out.update(window_s=float(t[-1] - t[0]), late_p50_ms=float(np.percentile(lag, 50)),
                       late_p99_ms=float(np.percentile(lag, 99)), late_max_ms=float(lag.max()),
                       drift_ms_per_min=_trend(t - t[0], lag) * 60.0)
        return out

    def align(self, t: float) -> float:
        """The first tick at or after ``t``."""
        return self._grid + math.ceil((t - self._grid) / self.tick - 1e-9) * self.tick

    def origin(self, t: float, Ts: float) -> float:
        """When sample 0 of a real-time run starting at ``t`` is due: one sample after the
        next tick. Sample ``k`` is then due at a tick when ``k + 1`` is a multiple of
        ``tick / Ts``; a run whose frames last one tick (20 samples at 1 kHz) gets exactly
        one frame per tick, sent at the tick its last sample is due."""
        return self.align(t) + Ts

    def _step(self, now: float) -> tuple[list[Block], list[Ended]]:
        groups: dict[int, list[_Live]] = {}
        for live in self._runs.values():
            n = self._due(live, now)
            if n > 0:
                groups.setdefault(n, []).append(live)
        blocks: list[Block] = []
        ended: list[Ended] = []
        for n, lives in groups.items():
            block = self._batch.advance(n, [live.slot for live in lives])
            # runs with the same columns (the same plant) are cut out of the block with
            # one copy and checked for divergence at once
            same: dict[tuple[int, ...], list[_Live]] = {}
            for live in lives:
                same.setdefault(live.cols, []).append(live)
            for group in same.values():
                slots = np.array([live.slot for live in group])
                data = block[np.ix_(slots, np.arange(n), np.array(group[0].cols))]
                with np.errstate(invalid="ignore"):
                    fine = (np.abs(data[:, :, 1:]) <= DIVERGENCE_LIMIT).all(axis=(1, 2))
                if not fine.all():
                    for i in np.flatnonzero(~fine):
                        blocks.append(self._record(group[i], data[i], ended))
                    group = [live for live, ok in zip(group, fine, strict=True) if ok]
                    data = data[fine]
                if group:
                    blocks.append(Block([live.id for live in group],
                                        [live.k for live in group], data))
                    for live in group:
                        live.k += n
        for live in [r for r in self._runs.values() if r.k >= r.run.n_samples]:
            ended.append(self._end(live, "finished"))
        return blocks, ended

    def _due(self, live: _Live, now: float) -> int:
        if live.paused_at is not None:
            return 0
        left = live.run.n_samples - live.k
        if live.pace == "fast":
            return min(self._fast_block, left)
        # + 1e-6: a sample due at the tick, up to rounding of the float times
        due = math.floor((now - live.t_origin) / live.run.Ts + 1e-6) + 1 - live.k
        return max(0, min(due, left, self._batch.block))

    def _record(self, live: _Live, data: Array, ended: list[Ended]) -> Block:
        """The samples of a run whose block failed the divergence check: those before it
        diverged (and the run fails), or all (a false alarm)."""
        i = first_divergence(data[:, 1:])  # u, y, x
        block = Block([live.id], [live.k], (data if i is None else data[:i])[np.newaxis])
        if i is not None:
            live.k += i
            msg = f"diverged at t = {live.k * live.run.Ts:.4g} s: the closed loop is unstable"
            ended.append(self._end(live, "failed", msg))
        else:
            live.k += data.shape[0]
        return block

    def _end(self, live: _Live, state: Literal["finished", "stopped", "failed"],
             error: str | None = None) -> Ended:
        del self._runs[live.id]
        self._batch.remove(live.slot)
        return Ended(live.id, state, live.k, error)


def _trend(t: Array, y: Array, parts: int = 12) -> float:
    """Slope of ``y`` over ``t`` (per unit of ``t``): Theil–Sen through the medians of
    ``parts`` equal spans of ``t``."""
    edges = np.linspace(t[0], t[-1], parts + 1)
    part = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, parts - 1)
    filled = [part == i for i in range(parts) if np.any(part == i)]
    if len(filled) < 2:
        return 0.0
    tm = np.array([np.median(t[m]) for m in filled])
    ym = np.array([np.median(y[m]) for m in filled])
    return float(scipy.stats.theilslopes(ym, tm)[0])
