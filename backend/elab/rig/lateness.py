"""How late a clock's wake-ups were: a histogram in 10 µs bins, summarised as
percentiles (the emulator logs it when it stops)."""

from __future__ import annotations

BIN_NS = 10_000
BINS = 1000  # up to 10 ms; later wake-ups count in the last bin


class Lateness:
    """Lateness of each sample (ns after its deadline) and the periods skipped."""

    def __init__(self, Ts_ns: int) -> None:
        self.Ts_ns = Ts_ns
        self.counts = [0] * BINS
        self.samples = 0
        self.skipped = 0
        self.late = 0  # samples more than Ts/2 late
        self.worst_ns = 0

    def record(self, late_ns: int, skipped: int) -> None:
        late_ns = max(0, late_ns)
        self.counts[min(BINS - 1, late_ns // BIN_NS)] += 1
        self.samples += 1
        self.skipped += skipped
        self.late += late_ns > self.Ts_ns // 2
        self.worst_ns = max(self.worst_ns, late_ns)

    def percentile(self, q: float) -> float:
        """The ``q`` quantile (0–1) of the lateness, s (to the 10 µs bin's upper edge)."""
        target, seen = q * self.samples, 0
        for i, n in enumerate(self.counts):
            seen += n
            if seen >= target and seen > 0:
                return (i + 1) * BIN_NS * 1e-9
        return 0.0

    def summary(self) -> str:
        return (
            f"{self.samples} samples; lateness median {self.percentile(0.5) * 1e3:.2f} ms, "
            f"p99 {self.percentile(0.99) * 1e3:.2f} ms, max {self.worst_ns * 1e-6:.2f} ms; "
            f"{self.late} more than half a period late, {self.skipped} periods skipped"
        )
