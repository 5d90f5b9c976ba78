"""How a run went, beyond its state: marks for what a "finished" alone would hide.

A run can reach its end and still have left its model's valid range, sat with its input
at the actuator's limit, asked for more than the actuator gives (saturation off), or let
its output run away from the reference. The recorder (:mod:`elab.engines.recorder`)
follows each run's samples as it commits them, off the stepping thread, and stores the
marks with the run's end (``outcome``: on its page, in the list, in the CSV header), each
with the sample where it began and a sentence naming the numbers.

The rules, each checked on the recorded (measured) samples:

- **left its range**: an output with a valid range (:attr:`Plant.output_ranges`: where
  the linear model holds, e.g. the double pendulum's links) outside it; the first sample.
- **saturated**: the input at the actuator's limit for at least :data:`SATURATED_S`
  seconds in a row and :data:`SATURATED_SHARE` of the samples; the longest stretch.
- **beyond the actuator**: saturation off and ``|u|`` above the actuator's limit; the
  first sample and the largest ``|u|``.
- **ran away**: a closed loop whose reference output ends more than :data:`RUNAWAY` times
  the reference's largest magnitude away from it (as the controller trial's "runs away"),
  that magnitude at least :data:`RUNAWAY_FLOOR` (5° or 50 mm: a loop held at r = 0); the
  first sample of the stretch, reaching the end, where it was that far off (measured
  against the reference's largest magnitude up to each sample).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elab.laws import has_feedback
from elab.sim.spec import CompiledRun

Array = NDArray[np.float64]

#: s in a row at the limit that make a run "saturated" (with the share below)
SATURATED_S = 1.0
#: share of the samples at the limit that make a run "saturated" (with the time above)
SATURATED_SHARE = 0.1
#: how many times the reference's largest magnitude the end may be off before "ran away"
RUNAWAY = 10.0
#: the least magnitude "ran away" measures against, by the output's unit: a loop held at
#: r = 0 (regulation, an input excitation) ran away only past 10 times this
RUNAWAY_FLOOR = {"rad": math.radians(5.0), "m": 0.05}
#: relative margin under the limit that counts as at the limit (round-off of the clip)
AT_LIMIT = 1e-9


@dataclass(frozen=True)
class _Range:
    col: int
    name: str
    unit: str
    lo: float
    hi: float


class OutcomeTracker:
    """Follows one run's recorded rows (``r, u, y…, x…``) in order: :meth:`add` each
    committed part, :meth:`marks` at any time (the run's so far)."""

    def __init__(
        self,
        Ts: float,
        channels: tuple[tuple[str, str], ...],
        *,
        u_max: float,
        saturate: bool,
        ranges: tuple[tuple[int, float, float], ...] = (),
        ref_output: int = 0,
        ref_offset: float = 0.0,
        feedback: bool = True,
    ) -> None:
        names = [n for n, _ in channels]
        self.Ts = Ts
        self.units = dict(channels)
        self.u_max = u_max
        self.saturate = saturate
        self._u = names.index("u")
        self._r = names.index("r")
        outputs = names[2:]  # r, u, then the outputs (then the states)
        self._ranges = tuple(
            _Range(2 + i, outputs[i], self.units[outputs[i]], lo, hi) for i, lo, hi in ranges
        )
        self._y = 2 + ref_output
        self._y_name = outputs[ref_output]
        self._offset = ref_offset
        self._feedback = feedback
        self.n = 0
        self._left: tuple[int, _Range, float] | None = None
        self._at_limit = 0
        self._run = 0  # the stretch at the limit ending at the last sample
        self._longest = (0, 0)  # (length, first sample) of the longest stretch
        self._beyond: tuple[int, float] | None = None  # first sample, largest |u|
        self._r_max = 0.0
        self._end: tuple[float, float] | None = None  # the last (r, y) measured
        self._away: int | None = None  # the first sample of the stretch far off, to now

    @classmethod
    def of(cls, run: CompiledRun, channels: tuple[tuple[str, str], ...]) -> OutcomeTracker:
        """The tracker of a compiled run recorded as ``channels``."""
        p = run.spec.plant
        offset = float((p.C @ p.operating_point)[p.reference_output])
        return cls(
            run.Ts,
            channels,
            u_max=p.u_max if run.spec.u_max is None else float(run.spec.u_max),
            saturate=math.isfinite(run.u_lim),
            ranges=p.output_ranges,
            ref_output=p.reference_output,
            ref_offset=offset,
            feedback=has_feedback(run.spec.law),
        )

    def add(self, k0: int, rows: Array) -> None:
        """The rows of samples ``k0 …`` (after every earlier one)."""
        n = rows.shape[0]
        if n == 0:
            return
        u = rows[:, self._u]
        with np.errstate(invalid="ignore"):
            if self._left is None:
                for rg in self._ranges:
                    y = rows[:, rg.col]
                    outside = np.flatnonzero((y < rg.lo) | (y > rg.hi))
                    if outside.size and (self._left is None or outside[0] < self._left[0] - k0):
                        self._left = (k0 + int(outside[0]), rg, float(y[outside[0]]))
            if self.saturate:
                self._limit(k0, np.abs(u) >= self.u_max * (1 - AT_LIMIT))
            else:
                beyond = np.flatnonzero(np.abs(u) > self.u_max * (1 + AT_LIMIT))
                if beyond.size:
                    peak = float(np.nanmax(np.abs(u[beyond])))
                    first = k0 + int(beyond[0]) if self._beyond is None else self._beyond[0]
                    self._beyond = (first, max(peak, self._beyond[1] if self._beyond else 0.0))
        r = rows[:, self._r]
        peak = float(np.nanmax(np.abs(r))) if not np.isnan(r).all() else math.nan
        if peak > self._r_max:
            self._r_max = peak
        if self._feedback:
            self._far_off(k0, rows[:, self._y], r)
        last_r, last_y = float(r[-1]), float(rows[-1, self._y])
        if math.isfinite(last_r) and math.isfinite(last_y):
            self._end = (last_r, last_y)
        else:  # the part ends with samples a rig dropped: its last measured one
            measured = np.flatnonzero(np.isfinite(rows[:, self._y]) & np.isfinite(r))
            if measured.size:
                self._end = (float(r[measured[-1]]), float(rows[measured[-1], self._y]))
        self.n = k0 + n

    def _far_off(self, k0: int, y: Array, r: Array) -> None:
        """Follow the stretch of samples more than :data:`RUNAWAY` times off the reference
        (a sample a rig dropped, NaN, neither ends nor starts one)."""
        unit = self.units.get(self._y_name, "")
        limit = RUNAWAY * max(self._r_max, RUNAWAY_FLOOR.get(unit, 1.0))
        with np.errstate(invalid="ignore"):
            err = np.abs(y - self._offset - r)
            far, near = err > limit, err <= limit
        last_near = np.flatnonzero(near)
        if last_near.size:
            after = np.flatnonzero(far[last_near[-1] + 1 :])
            self._away = k0 + int(last_near[-1]) + 1 + int(after[0]) if after.size else None
        elif self._away is None:
            first = np.flatnonzero(far)
            self._away = k0 + int(first[0]) if first.size else None

    def _limit(self, k0: int, at: NDArray[np.bool_]) -> None:
        """Count the samples at the limit and the longest stretch of them, across parts."""
        count = int(np.count_nonzero(at))
        if count == 0:  # (the usual part: a few microseconds, on the writer's thread)
            self._run = 0
            return
        self._at_limit += count
        turns = np.diff(np.r_[False, at, False].astype(np.int8))
        starts, stops = np.flatnonzero(turns == 1), np.flatnonzero(turns == -1)
        for a, b in zip(starts.tolist(), stops.tolist(), strict=True):
            length, first = b - a, k0 + a
            if a == 0:  # goes on from the stretch that ended the last part
                length, first = length + self._run, first - self._run
            if length > self._longest[0]:
                self._longest = (length, first)
        n = at.size
        if stops.size and stops[-1] == n:  # a stretch reaches the part's end
            a = int(starts[-1])
            self._run = n - a + (self._run if a == 0 else 0)
        else:
            self._run = 0

    def marks(self) -> list[dict[str, Any]]:
        """The run's marks so far, in the order of the sample each began at: ``kind``
        (``left_range``, ``saturated``, ``beyond_actuator``, ``ran_away``), ``k``, ``t``
        (s) and ``text``."""
        out: list[dict[str, Any]] = []
        if self._left is not None:
            k, rg, value = self._left
            out.append(
                self._mark(
                    "left_range",
                    k,
                    f"{rg.name} left the model's valid range ({_q(rg.lo, rg.unit)} to "
                    f"{_q(rg.hi, rg.unit)}) at t = {k * self.Ts:.4g} s ({_q(value, rg.unit)}): "
                    "from there the run is not what the linear model describes",
                )
            )
        length, first = self._longest
        if (
            self.n
            and length * self.Ts >= SATURATED_S
            and self._at_limit >= SATURATED_SHARE * self.n
        ):
            share = self._at_limit / self.n
            out.append(
                self._mark(
                    "saturated",
                    first,
                    f"u sat at the actuator's limit ±{self.u_max:g} V for {share:.0%} of the "
                    f"run, {length * self.Ts:.4g} s in a row from t = {first * self.Ts:.4g} s: "
                    "the controller asked for more than the motor gives",
                )
            )
        if self._beyond is not None:
            k, peak = self._beyond
            out.append(
                self._mark(
                    "beyond_actuator",
                    k,
                    f"|u| went beyond the actuator's ±{self.u_max:g} V from t = "
                    f"{k * self.Ts:.4g} s, up to {peak:.4g} V (saturation off: a real "
                    "motor would not follow)",
                )
            )
        if self._feedback and self._end is not None:
            r, y = self._end
            err = abs(y - self._offset - r)
            unit = self.units.get(self._y_name, "")
            scale = max(self._r_max, RUNAWAY_FLOOR.get(unit, 1.0))
            if err > RUNAWAY * scale:
                k = self.n - 1 if self._away is None else self._away
                out.append(
                    self._mark(
                        "ran_away",
                        k,
                        f"{self._y_name} ran away from t = {k * self.Ts:.4g} s and ended "
                        f"{_q(err, unit)} from the reference"
                        + (
                            f", {err / self._r_max:.3g} times its largest value"
                            if self._r_max > 0
                            else " (held at 0)"
                        )
                        + ": the loop is unstable, or a sign is wrong",
                    )
                )
        return sorted(out, key=lambda m: int(m["k"]))

    def _mark(self, kind: str, k: int, text: str) -> dict[str, Any]:
        return {"kind": kind, "k": int(k), "t": k * self.Ts, "text": text}


def _q(value: float, unit: str) -> str:
    """A value as the pages show it: degrees for radians, mm for metres."""
    if unit == "rad":
        return f"{math.degrees(value):.4g}°"
    if unit == "m":
        return f"{value * 1e3:.4g} mm"
    return f"{value:.4g} {unit}".rstrip()
