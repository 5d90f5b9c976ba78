"""How the stepping thread keeps time: a record of its ticks (how late each began, how
far the runs' clocks lag) summed up as the engine's timing, and the scheduling policies
its threads run under."""

from __future__ import annotations

import logging
import os
from collections import deque

import numpy as np
import scipy.stats
from numpy.typing import NDArray

log = logging.getLogger(__name__)

Array = NDArray[np.float64]


class TickLog:
    """The last minute's ticks: (scheduled time, how late the tick began, how far the runs'
    clocks lag after it). ``add`` from the stepping thread, ``timing`` from any."""

    def __init__(self, tick: float) -> None:
        self.tick = tick
        self._late: deque[tuple[float, float, float]] = deque(maxlen=round(60.0 / tick))

    def add(self, scheduled: float, late: float, clock_lag: float) -> None:
        self._late.append((scheduled, late, clock_lag))

    def entries(self) -> Array:
        """The ticks kept, oldest first: rows of (scheduled, late, clock lag), in s."""
        return np.array(self._late.copy()).reshape(-1, 3)  # deque.copy is atomic

    def timing(self, ticks: int) -> dict[str, float | int]:
        """How closely the ticks of the last minute kept to their schedule: how late they
        began (ms; p50, p99, max) and the trend of that lateness (ms per minute): the
        Theil–Sen slope of its medians over 12 equal parts of the minute, which one long
        stall does not tilt. A real-time sample is computed at the first tick at or after
        its due time, so this trend is the drift of the runs' clocks against the monotonic
        clock."""
        late = self.entries()
        out: dict[str, float | int] = {
            "ticks": ticks,
            "tick_s": self.tick,
            "window_s": 0.0,
            "late_p50_ms": 0.0,
            "late_p99_ms": 0.0,
            "late_max_ms": 0.0,
            "drift_ms_per_min": 0.0,
            "tick_rate": 0.0,
            "clock_lag_max_ms": 0.0,
        }
        if late.shape[0] >= 2:
            t, lag = late[:, 0], late[:, 1] * 1e3
            window = float(t[-1] - t[0])
            out.update(
                window_s=window,
                late_p50_ms=float(np.percentile(lag, 50)),
                late_p99_ms=float(np.percentile(lag, 99)),
                late_max_ms=float(lag.max()),
                drift_ms_per_min=_trend(t - t[0], lag) * 60.0,
                tick_rate=(late.shape[0] - 1) / window if window > 0 else 0.0,
                clock_lag_max_ms=float(late[:, 2].max() * 1e3),
            )
        return out


def realtime_thread(priority: int) -> int:
    """Put the calling thread under SCHED_FIFO at ``priority``: it then runs whenever it is
    ready, ahead of every ordinary thread of any process (the web process, the
    identification workers, this process's writer). It sleeps between ticks and needs a few
    percent of a core. Needs CAP_SYS_NICE; returns the priority it got (0: refused)."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))  # 0: this thread
    except (OSError, AttributeError) as exc:
        log.warning("real-time scheduling of the stepping thread refused: %s", exc)
        return 0
    return priority


def ordinary_thread() -> None:
    """Put the calling thread under the ordinary scheduler (the engine process may be
    real-time, and its threads inherit that): a thread that waits for a student's code
    must never keep an ordinary process from running."""
    try:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (OSError, AttributeError) as exc:
        log.warning("could not make a code run's thread ordinary: %s", exc)


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
