"""The server's status and health: stepping timing, the engine, the store, the workers."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from elab.api.schemas.base import Model


class StepperTiming(Model):
    """The stepping thread over the last minute of ticks, and the runs with Python
    controllers, each stepped by a thread of its own."""

    ticks: int = Field(default=0, description="ticks since the server started")
    tick_s: float = Field(default=0.0, description="tick period (s)")
    window_s: float = Field(default=0.0, description="time spanned by the ticks below (s)")
    late_p50_ms: float = Field(default=0.0, description="how late a tick began: median (ms)")
    late_p99_ms: float = 0.0
    late_max_ms: float = 0.0
    drift_ms_per_min: float = Field(
        default=0.0,
        description="trend of that lateness (ms per minute): the drift of real-time runs' clocks",
    )
    tick_rate: float = Field(
        default=0.0, description="ticks per second over the window (the plan: 1 / tick_s)"
    )
    clock_lag_max_ms: float = Field(
        default=0.0,
        description="how far the most belated real-time run's clock fell behind the wall clock "
        "after a tick (ms): a tick that overran shows here even if the next is on time",
    )
    code_runs: int = Field(default=0, description="live runs with Python controllers")
    code_clock_lag_max_ms: float = Field(
        default=0.0,
        description="the same for the runs with Python controllers: a slow controller delays "
        "its own run's clock, nobody else's",
    )


class EngineInfo(Model):
    """The engine that steps runs, as the web process sees it."""

    id: str
    up: bool = Field(description="started and answering")
    problem: str | None = Field(description="why it is not up, or what is wrong while up")
    restarts: int = Field(description="restarts after its process was lost")
    pid: int | None
    heartbeat_age_s: float | None = Field(description="since it last reported (s)")
    live_runs: int | None = Field(default=None, description="its live runs, as it last said")


class StoreInfo(Model):
    """The engine's writes to the run store."""

    ok: bool
    error: str | None
    since: float | None = Field(description="failing since (unix s)")
    transient: bool = Field(
        description="being retried (a lock held elsewhere); else failed "
        "until someone acts: new runs get 503"
    )
    pending_bytes: int = Field(description="samples waiting in memory to be committed")


class JobsInfo(Model):
    """The identification workers."""

    workers: int
    busy: int = Field(description="workers running a job")
    starting: int = Field(
        description="workers still starting (a fresh one replaces one whose job was stopped)"
    )


class UploadsInfo(Model):
    """Large bodies (uploads, identification data) being received."""

    receiving: int
    limit: int = Field(description="ELAB_MAX_UPLOADS: more at once get 429")


class RigInfo(Model):
    """The flexible-link rig of this server, if it has one (``ELAB_RIG``)."""

    engine: EngineInfo
    connected: bool = Field(description="the rig answers the host loop")
    rig_id: str | None
    firmware: str | None
    emulated: bool = Field(description="an elab rig-emulator process, not hardware")
    problem: str | None = Field(description="why it is not connected, or out of service")
    settling: bool = Field(description="after a run: 0 V until still, then re-zero")
    samples: int = Field(description="samples the host loop answered since it started")
    late_1ms: int = Field(description="of them, answered more than 1 ms after arriving")
    latency_p50_us: float | None = Field(description="response latency, last 10 s (µs)")
    latency_p99_us: float | None
    latency_max_us: float | None


class DeliveryInfo(Model):
    """The watchers' side of the streams: what tick lateness cannot show (a stepper on
    time whose frames wait in a slow watcher's queue)."""

    lag_max_ms: float = Field(
        description="how far the most belated watcher is behind its run's stream (ms): the "
        "samples published that it has not been sent yet"
    )
    catching_up: int = Field(
        description="watchers served from the recording (they fell behind, or joined late)"
    )
    skipping: int = Field(
        description="watchers too slow for their queue (ELAB_WATCHER_FRAMES): frames are "
        "skipped for them, which they are told when they read again"
    )


class ServerStatus(Model):
    live_runs: int
    watchers: int = Field(description="websocket watchers connected, all runs")
    delivery: DeliveryInfo
    stepper: StepperTiming
    engine: EngineInfo = Field(
        description="the simulation engine (on a broker: the busiest of those up, or why none is)"
    )
    engines: list[EngineInfo] = Field(
        description="each simulation engine process: the server's own, or each engine on "
        "the broker (ELAB_REDIS_URL) that has reported"
    )
    store: StoreInfo
    ident: JobsInfo
    uploads: UploadsInfo
    rig: RigInfo | None = Field(description="the rig, if this server has one")


class HealthInfo(Model):
    """For a load balancer: ``ok`` (200); ``degraded`` (200: runs work, something is being
    retried, e.g. a store locked by another writer); ``unavailable`` (503: new runs would
    fail: the engine is down or stalled, or the store has failed). ``problems`` says what."""

    status: Literal["ok", "degraded", "unavailable"]
    problems: list[str]


class HelpEntry(Model):
    """A documentation page the app offers: its ``name`` (``GET /help/{name}``) and what
    it is for."""

    name: str
    summary: str


class HelpIndex(Model):
    pages: list[HelpEntry]


class HelpPage(Model):
    """A documentation page: its title (its first heading) and its markdown (links to
    other pages as ``name.md``)."""

    name: str
    title: str
    markdown: str
