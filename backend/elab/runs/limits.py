"""What one run, and one identity, may ask of the server: checked before anything starts.

Each limit is an environment setting of ``elab serve`` (docs/operations.md);
a run over a size limit gets :class:`~elab.errors.InvalidInput` naming the field
and what is allowed (HTTP 422), an identity over a count or storage limit gets
:class:`~elab.errors.TooMany` saying which limit and when to retry (HTTP 429).
"""

from __future__ import annotations

from dataclasses import dataclass

from elab.errors import InvalidInput
from elab.sim.spec import RunSpec


@dataclass(frozen=True)
class Limits:
    """``max_live`` runs live on the server (``ELAB_MAX_LIVE_RUNS``) and per identity
    (``ELAB_MAX_LIVE_PER_IDENTITY``); ``max_duration`` s per run (``ELAB_MAX_DURATION``);
    ``max_samples`` per run (``ELAB_MAX_RUN_SAMPLES``); ``max_recording`` bytes per
    recording (``ELAB_MAX_RECORDING``); the sample time at least the plant's default
    divided by ``ts_ratio`` (``ELAB_TS_RATIO``). Kept runs: ``max_runs_per_identity``
    (``ELAB_MAX_RUNS_PER_IDENTITY``) and ``max_storage_per_identity`` bytes of samples
    (``ELAB_MAX_STORAGE_PER_IDENTITY``), ended runs deleted ``retention`` s after they
    ended (``ELAB_RETENTION``; 0: kept for ever). Runs nobody watches: a real-time run
    whose owner has had no connection to it for ``owner_grace`` s pauses
    (``ELAB_OWNER_GRACE``) and stops at ``owner_gone`` s (``ELAB_OWNER_GONE``)."""

    max_live: int = 400
    max_live_per_identity: int = 20
    max_runs_per_identity: int = 500
    max_storage_per_identity: int = 2 << 30
    retention: float = 30 * 86400.0
    owner_grace: float = 60.0
    owner_gone: float = 600.0
    max_duration: float = 3600.0
    max_samples: int = 3_600_000
    max_recording: int = 256 << 20
    ts_ratio: float = 10.0

    def check(self, spec: RunSpec, channels: int) -> None:
        """A run's size against the limits (before it is compiled: a sample time of 1e-300
        would otherwise ask for a 1e303-sample discretisation)."""
        plant = spec.plant
        Ts = plant.Ts if spec.Ts is None else spec.Ts
        lowest = plant.Ts / self.ts_ratio
        if not Ts >= lowest:
            raise InvalidInput(
                "Ts",
                Ts,
                f"a sample time ≥ {lowest:g} s for {plant.id} (its "
                f"default {plant.Ts:g} s / {self.ts_ratio:g}, ELAB_TS_RATIO)",
            )
        if not 0 < spec.duration <= self.max_duration:
            raise InvalidInput(
                "duration",
                spec.duration,
                f"a duration in (0, {self.max_duration:g}] s (ELAB_MAX_DURATION)",
            )
        n = round(spec.duration / Ts)
        if n > self.max_samples:
            raise InvalidInput(
                "duration",
                spec.duration,
                f"at most {self.max_samples} samples per run "
                f"(ELAB_MAX_RUN_SAMPLES): with Ts = {Ts:g} s a duration "
                f"≤ {self.max_samples * Ts:g} s",
            )
        size = n * channels * 8
        if size > self.max_recording:
            longest = self.max_recording // (channels * 8) * Ts
            raise InvalidInput(
                "duration",
                spec.duration,
                f"a recording of at most {self.max_recording} bytes "
                f"(ELAB_MAX_RECORDING; {channels} channels of 8-byte samples): "
                f"with Ts = {Ts:g} s a duration ≤ {longest:g} s",
            )
