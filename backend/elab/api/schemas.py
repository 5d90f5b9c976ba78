"""The wire protocol ``elab.v1``: every request, response and websocket message.

These pydantic models are the single source of truth: the OpenAPI document,
``shared/elab.v1.schema.json`` and the app's TypeScript types are generated
from them (a test fails when the committed copies drift).
"""

from __future__ import annotations

from enum import IntEnum
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

PROTOCOL = "elab.v1"
Finite = float  # with allow_inf_nan=False below, NaN and ±inf are refused everywhere


class Model(BaseModel):
    model_config = ConfigDict(
        extra="forbid",
        allow_inf_nan=False,
        frozen=True,
        json_schema_serialization_defaults_required=True,
    )


# -- controllers ------------------------------------------------------------------
class PredefinedController(Model):
    """The plant's predefined controller."""

    kind: Literal["predefined"] = "predefined"


class StateFeedbackController(Model):
    """u = K (x_ref − x̂): one gain per state."""

    kind: Literal["state_feedback"] = "state_feedback"
    K: list[Finite] = Field(min_length=1, max_length=64)
    estimate: Literal["true_state", "velocity_filters"] = "velocity_filters"


class PIDController(Model):
    """C(s) = Kp + Ki/s + Kd s/(Tf s + 1), Tf = Kd/(N Kp), on e = r − y."""

    kind: Literal["pid"] = "pid"
    Kp: Finite
    Ki: Finite = 0.0
    Kd: Finite = 0.0
    N: Finite = Field(10.0, gt=0)
    Tt: Finite | None = Field(None, gt=0, description="anti-windup tracking time (s)")


class LTIControllerModel(Model):
    """Any SISO LTI controller on e = r − y: num/den or A, B, C, D; dt = null: continuous."""

    kind: Literal["lti"] = "lti"
    num: list[Finite] | None = Field(None, max_length=64)
    den: list[Finite] | None = Field(None, max_length=64)
    A: list[list[Finite]] | None = Field(None, max_length=64)
    B: list[list[Finite]] | None = Field(None, max_length=64)
    C: list[list[Finite]] | None = Field(None, max_length=1)
    D: list[list[Finite]] | None = Field(None, max_length=1)
    dt: Finite | None = Field(None, gt=0)


class OpenLoopController(Model):
    """No feedback: the signal is the plant input (V)."""

    kind: Literal["open_loop"] = "open_loop"


Controller = Annotated[
    PredefinedController
    | StateFeedbackController
    | PIDController
    | LTIControllerModel
    | OpenLoopController,
    Field(discriminator="kind"),
]


# -- signals ------------------------------------------------------------------------
class StepSignal(Model):
    kind: Literal["step"] = "step"
    amplitude: Finite
    t0: Finite = Field(0.0, ge=0)
    offset: Finite = 0.0


class SquareSignal(Model):
    kind: Literal["square"] = "square"
    amplitude: Finite
    period: Finite = Field(gt=0)
    offset: Finite = 0.0
    duty: Finite = Field(0.5, gt=0, le=1)


class SineSignal(Model):
    kind: Literal["sine"] = "sine"
    amplitude: Finite
    frequency: Finite = Field(gt=0, description="Hz")
    phase: Finite = 0.0
    offset: Finite = 0.0


class ChirpSignal(Model):
    kind: Literal["chirp"] = "chirp"
    amplitude: Finite
    f0: Finite = Field(ge=0)
    f1: Finite = Field(gt=0)
    sweep: Finite = Field(gt=0)
    offset: Finite = 0.0


class PRBSSignal(Model):
    kind: Literal["prbs"] = "prbs"
    amplitude: Finite
    order: int = Field(10, ge=3, le=20)
    band: Finite = Field(1.0, gt=0, le=1)
    offset: Finite = 0.0


class SamplesSignal(Model):
    kind: Literal["samples"] = "samples"
    values: list[Finite] = Field(min_length=1, max_length=100_000)


Signal = Annotated[
    StepSignal | SquareSignal | SineSignal | ChirpSignal | PRBSSignal | SamplesSignal,
    Field(discriminator="kind"),
]


# -- runs --------------------------------------------------------------------------
class RunCreate(Model):
    """A run to start. Omitted fields take the plant's defaults; units are SI."""

    plant: str = Field(min_length=1, max_length=64)
    mode: Literal["simulation", "rig"] = "simulation"
    experiment: Literal["analysis", "identification", "design"] = "analysis"
    controller: Controller = PredefinedController()
    signal: Signal | None = None
    excitation: Signal | None = None
    excitation_at: Literal["reference", "input"] = "input"
    duration: Finite | None = Field(None, gt=0, description="s")
    pace: Literal["realtime", "fast"] = "realtime"
    seed: int | None = Field(None, ge=0, le=2**63 - 1, description="sensor noise seed")
    quantize: bool = False
    saturate: bool | None = None
    Ts: Finite | None = Field(None, gt=0)
    x0: list[Finite] | None = Field(None, max_length=64)


class ChannelInfo(Model):
    name: str
    unit: str


class ParamChangeInfo(Model):
    k: int
    t: float
    at: float
    params: dict[str, Any]


RunStateName = Literal[
    "created", "running", "paused", "finished", "stopped", "failed", "interrupted"
]


class RunSummaryInfo(Model):
    """A run in a list: without its request and parameter changes (``GET /runs/{id}``
    has them)."""

    id: str
    plant: str
    mode: str
    experiment: str
    status: RunStateName
    Ts: float
    channels: list[ChannelInfo]
    n_planned: int
    n_samples: int
    created_at: float
    started_at: float | None
    finished_at: float | None
    error: str | None = Field(description="why it failed, stopped early or was interrupted")
    url: str


class RunInfo(RunSummaryInfo):
    frame_samples: int
    stream_url: str
    data_url: str
    request: dict[str, Any]
    param_changes: list[ParamChangeInfo] = []


class StepperTiming(Model):
    """The stepping thread over the last minute of ticks."""

    ticks: int = Field(description="ticks since the server started")
    tick_s: float = Field(description="tick period (s)")
    window_s: float = Field(description="time spanned by the ticks below (s)")
    late_p50_ms: float = Field(description="how late a tick began: median (ms)")
    late_p99_ms: float
    late_max_ms: float
    drift_ms_per_min: float = Field(
        description="trend of that lateness (ms per minute): the drift of real-time runs' clocks"
    )


class EngineInfo(Model):
    """The engine that steps runs, as the web process sees it."""

    id: str
    up: bool = Field(description="started and answering")
    problem: str | None = Field(description="why it is not up, or what is wrong while up")
    restarts: int = Field(description="restarts after its process was lost")
    pid: int | None
    heartbeat_age_s: float | None = Field(description="since it last reported (s)")


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
    busy: int


class ServerStatus(Model):
    live_runs: int
    watchers: int = Field(description="websocket watchers connected, all runs")
    stepper: StepperTiming
    engine: EngineInfo
    store: StoreInfo
    ident: JobsInfo


class HealthInfo(Model):
    """For a load balancer: ``ok`` (200); ``degraded`` (200: runs work, something is being
    retried, e.g. a store locked by another writer); ``unavailable`` (503: new runs would
    fail: the engine is down or stalled, or the store has failed). ``problems`` says what."""

    status: Literal["ok", "degraded", "unavailable"]
    problems: list[str]


class RunList(Model):
    runs: list[RunSummaryInfo]
    total: int
    limit: int
    offset: int


class ParamsUpdate(Model):
    """New controller gains and/or reference, applied from the next sample."""

    controller: Controller | None = None
    signal: Signal | None = None


class ParamsApplied(Model):
    k: int = Field(description="first sample computed with the new parameters")
    t: float


# -- plants, analysis, design ------------------------------------------------------
class Complex(Model):
    re: float
    im: float


class PlantSummary(Model):
    id: str
    name: str
    summary: str
    modes: list[str]
    experiments: list[str]


class PlantChannel(Model):
    name: str
    unit: str
    label: str


class PlantDetail(PlantSummary):
    A: list[list[float]]
    B: list[list[float]]
    C: list[list[float]]
    D: list[list[float]]
    states: list[PlantChannel]
    inputs: list[PlantChannel]
    outputs: list[PlantChannel]
    u_max: float
    saturate: bool
    Ts: float
    reference_output: str
    operating_point: list[float]
    initial_state_ranges: list[tuple[str, float, float]]
    predefined: Controller
    predefined_design: str
    default_signal: Signal
    default_duration: float
    sensors: dict[str, list[float]]
    description: str


class RankInfo(Model):
    rank: int
    n: int
    full: bool
    condition_number: float | None
    singular_values: list[float]


class TransferFunctionInfo(Model):
    output: str
    input: str
    num: list[float]
    den: list[float]
    text: str
    latex: str


class AnalysisInfo(Model):
    plant: str
    eigenvalues: list[Complex]
    verdict: Literal["asymptotically stable", "marginally stable", "unstable"]
    reason: str
    controllability: RankInfo
    observability: RankInfo
    transfer_functions: list[TransferFunctionInfo]


class BodeInfo(Model):
    output: str
    omega: list[float] = Field(description="rad/s")
    hz: list[float]
    mag_db: list[float]
    phase_deg: list[float]


class BodeList(Model):
    plant: str
    input: str
    bode: list[BodeInfo]


class StepRequest(Model):
    """Open loop (controller omitted or open_loop) or closed loop with a controller."""

    controller: Controller | None = None
    T: Finite | None = Field(None, gt=0, le=3600, description="final time (s)")
    amplitude: Finite = 1.0
    n: int = Field(2001, ge=2, le=100_000)


class StepInfoOut(Model):
    rise_time: float | None
    settling_time: float | None
    overshoot: float | None
    peak: float | None
    peak_time: float | None
    steady_state: float | None
    steady_state_error: float | None


class StepOut(Model):
    plant: str
    loop: Literal["open", "closed"]
    t: list[float]
    outputs: dict[str, list[float]]
    u: list[float]
    info: StepInfoOut | None = Field(description="of the reference output (closed loop)")
    poles: list[Complex]
    verdict: str


class LQRRequest(Model):
    Q: list[Finite] | list[list[Finite]] = Field(description="diagonal or full matrix")
    R: Finite | list[list[Finite]] = 1.0


class PlaceRequest(Model):
    poles: list[Complex] = Field(min_length=1, max_length=64)


class DesignOut(Model):
    plant: str
    method: Literal["lqr", "place"]
    K: list[float]
    closed_loop_poles: list[Complex]
    convention: str = "u = K (x_ref - x)"


# -- identification ------------------------------------------------------------------
Channels = Annotated[
    list[Annotated[str, Field(min_length=1, max_length=64)]], Field(min_length=1, max_length=8)
]
Span = Annotated[
    list[Annotated[int, Field(ge=0, le=50)]],
    Field(min_length=2, max_length=2, description="[lowest, highest], inclusive"),
]


class RunData(Model):
    """The recording of a run (columns by channel name, e.g. ``u`` and ``theta``)."""

    source: Literal["run"] = "run"
    run: str = Field(min_length=1, max_length=64)
    input: Channels = ["u"]
    output: Channels | None = Field(None, description="default: the plant's reference output")
    t_from: Finite | None = Field(None, ge=0, description="s")
    t_to: Finite | None = Field(None, gt=0, description="s")


class FileData(Model):
    """An uploaded table: an E-Lab CSV/JSON download, or plain numeric columns
    (comma- or whitespace-separated; unnamed columns are c1, c2, …)."""

    source: Literal["file"] = "file"
    format: Literal["csv", "json"] = "csv"
    name: str = Field("upload", max_length=200)
    text: str = Field(min_length=1, description="the file's content")
    input: Channels
    output: Channels
    Ts: Finite | None = Field(None, gt=0, description="s; default: from the file")


Order = Annotated[int, Field(ge=1, le=50)]  # a polynomial's number of coefficients
Lags = Annotated[int, Field(ge=0, le=50)]  # na (none allowed) and the delay nk


class ArxSpec(Model):
    kind: Literal["arx"] = "arx"
    na: Lags
    nb: Order
    nk: Lags = 1


class ArmaxSpec(Model):
    kind: Literal["armax"] = "armax"
    na: Lags
    nb: Order
    nc: Order
    nk: Lags = 1


class OeSpec(Model):
    kind: Literal["oe"] = "oe"
    nb: Order
    nf: Order
    nk: Lags = 1


class N4sidSpec(Model):
    kind: Literal["n4sid"] = "n4sid"
    order: int = Field(0, ge=0, le=99, description="0: chosen from the singular values")
    horizon: int = Field(0, ge=0, le=100, description="block rows; 0: the default")


ModelSpec = Annotated[ArxSpec | ArmaxSpec | OeSpec | N4sidSpec, Field(discriminator="kind")]


class ArxSearch(Model):
    na: Span = [1, 10]
    nb: Span = [1, 10]
    nk: Span = [1, 10]


class IdentRequest(Model):
    """Identification on a run's data or an uploaded table. ``split``: the estimation
    share (the first part); the rest validates. Send ``Accept: application/x-ndjson`` to
    receive progress lines before the result."""

    data: Annotated[RunData | FileData, Field(discriminator="source")]
    detrend: Literal["mean", "linear", "none"] = "mean"
    split: Finite = Field(0.5, gt=0, lt=1)
    correlation: bool = True
    max_lag: int = Field(30, ge=1, le=500)
    spectral: bool = True
    sine_hz: Finite | None = Field(None, gt=0, description="Hz; default: a run's sine signal")
    arx_search: ArxSearch | None = None
    n4sid_orders: Span | None = None
    horizon: int | None = Field(None, ge=2, le=100)
    models: list[ModelSpec] = Field([], max_length=10)


class IdentOut(Model):
    """``data``: the (detrended) samples, thinned to ≤ 5000 points for plotting;
    ``analyses``: correlation, spectral, sine, arx_search, n4sid_orders (those asked for);
    ``models``: each with fit %, polynomials or matrices, transfer functions, poles,
    simulated and one-step outputs on the validation set and its residual analysis."""

    data: dict[str, Any]
    analyses: dict[str, Any]
    models: list[dict[str, Any]]
    notes: list[str]


# -- errors --------------------------------------------------------------------------
class FieldError(Model):
    field: str
    message: str


class ErrorDetail(Model):
    code: Literal["invalid", "not_found", "conflict", "too_many", "too_large", "unavailable"]
    message: str
    field: str | None = None
    errors: list[FieldError] = []


class ErrorBody(Model):
    error: ErrorDetail


# -- websocket messages ------------------------------------------------------------
class CloseCode(IntEnum):
    """Why the server closes a stream (the close frame's reason says more): 4400 the
    request was wrong (no ``elab.v1`` subprotocol, a bad ``from_seq``), 4404 no such run.
    A client should not reconnect after either."""

    BAD_REQUEST = 4400
    NOT_FOUND = 4404


class Hello(Model):
    type: Literal["hello"] = "hello"
    protocol: Literal["elab.v1"] = "elab.v1"
    run: RunInfo
    live_seq: int = Field(description="seq of the next live frame")


class Frame(Model):
    """Samples k0 .. k0+n−1: float32 little-endian bytes per channel (t = k·Ts)."""

    type: Literal["frame"] = "frame"
    seq: int
    k0: int
    n: int
    columns: dict[str, bytes]


class Status(Model):
    type: Literal["status"] = "status"
    state: RunStateName
    k: int
    error: str | None = None


class Skipped(Model):
    type: Literal["skipped"] = "skipped"
    from_seq: int
    to_seq: int
    reason: str


class ParamsNotice(Model):
    type: Literal["params"] = "params"
    k: int
    t: float
    params: dict[str, Any]


class ErrorMessage(Model):
    type: Literal["error"] = "error"
    code: str
    message: str
    field: str | None = None


ServerMessage = Annotated[
    Hello | Frame | Status | Skipped | ParamsNotice | ErrorMessage, Field(discriminator="type")
]


class SetParams(Model):
    type: Literal["set_params"]
    controller: Controller | None = None
    signal: Signal | None = None


class Pause(Model):
    type: Literal["pause"]


class Resume(Model):
    type: Literal["resume"]


class Stop(Model):
    type: Literal["stop"]


class ResumeFrom(Model):
    """Send every sample from frame ``seq`` on, from the recording."""

    type: Literal["resume_from"]
    seq: int = Field(ge=0)


ClientMessage = Annotated[
    SetParams | Pause | Resume | Stop | ResumeFrom, Field(discriminator="type")
]
