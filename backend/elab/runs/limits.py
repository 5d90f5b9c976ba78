"""What one run, and one identity, may ask of the server: checked before anything starts.

Each limit is an environment setting of ``elab serve`` (docs/operations.md);
a run over a size limit gets :class:`~elab.errors.InvalidInput` naming the field
and what is allowed (HTTP 422), an identity over a count or storage limit gets
:class:`~elab.errors.TooMany` saying which limit and when to retry (HTTP 429).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from elab.errors import InvalidInput, TooMany
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

    def check_live(self, live: int, mine: int | None) -> None:
        """Room for one more live run: ``live`` runs live or starting on the server,
        ``mine`` of them the asking identity's (``None``: a caller of no identity)."""
        if live >= self.max_live:
            raise TooMany(
                f"{live} runs are live, the limit of this server "
                f"(ELAB_MAX_LIVE_RUNS = {self.max_live}); retry when one has ended",
                retry_after=10.0,
            )
        if mine is not None and mine >= self.max_live_per_identity:
            raise TooMany(
                f"you have {mine} live runs, the limit per identity "
                f"(ELAB_MAX_LIVE_PER_IDENTITY = {self.max_live_per_identity}); "
                "stop one or retry when one has ended",
                retry_after=10.0,
            )

    def check_kept(self, runs: int, held: int, size: int) -> None:
        """Room to keep one more run of ``size`` bytes for an identity that keeps ``runs``
        runs holding ``held`` bytes (live ones at their planned size)."""
        retry, hint = self._retry_hint()
        if runs + 1 > self.max_runs_per_identity:
            raise TooMany(
                f"you keep {runs} runs, the limit per identity "
                f"(ELAB_MAX_RUNS_PER_IDENTITY = {self.max_runs_per_identity}); delete some "
                f"under My runs{hint}",
                retry_after=retry,
            )
        if held + size > self.max_storage_per_identity:
            raise TooMany(
                f"your runs hold {_mib(held)} and this one needs "
                f"{_mib(size)}, over the storage per identity (ELAB_MAX_STORAGE_PER_IDENTITY"
                f" = {_mib(self.max_storage_per_identity)}); delete runs under My runs or "
                f"start a shorter run{hint}",
                retry_after=retry,
            )

    def _retry_hint(self) -> tuple[float, str]:
        """When an identity over its storage budget gains room by itself: its oldest
        ended run is deleted at most ``retention`` s from now."""
        r = self.retention
        if r <= 0:
            return 3600.0, ""
        return r, f", or retry when old runs expire (ELAB_RETENTION = {r:g} s after they end)"

    def unwatched(self, gone: float, running: bool) -> tuple[Literal["pause", "stop"], str] | None:
        """What becomes of a real-time run whose owner has had no connection to it for
        ``gone`` s (``running``: running, and not paused for that already), and why."""
        if gone >= self.owner_gone:
            return "stop", (
                f"stopped: its owner had no connection to it for {self.owner_gone:g} s "
                f"(paused after {self.owner_grace:g} s; ELAB_OWNER_GRACE, ELAB_OWNER_GONE)"
            )
        if gone >= self.owner_grace and running:
            return "pause", (
                f"paused: its owner has had no connection to it for {self.owner_grace:g} s "
                f"(ELAB_OWNER_GRACE); it stops {self.owner_gone - self.owner_grace:g} s later "
                "unless its owner resumes it"
            )
        return None


def _mib(n: int) -> str:
    return f"{n / (1 << 20):.1f} MiB"
