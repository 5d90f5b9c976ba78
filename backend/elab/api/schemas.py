"""The wire protocol ``elab.v1``: every request, response and websocket message.

These pydantic models are the single source of truth: the OpenAPI document,
``shared/elab.v1.schema.json`` and the app's TypeScript types are generated
from them (a test fails when the committed copies drift).
"""

from __future__ import annotations

import math
from enum import IntEnum
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, RootModel, field_validator
from pydantic.json_schema import SkipJsonSchema

from elab.sim.signals import PRBS_MIN_BAND

PROTOCOL = "elab.v1"
Finite = float  # with allow_inf_nan=False below, NaN and ±inf are refused everywhere


class Model(BaseModel):
    """Strict: a value is taken only in the JSON type its schema names (``true`` is not a
    number, ``"1"`` not an integer), so what the OpenAPI document accepts and what the
    server accepts are the same set."""

    model_config = ConfigDict(
        extra="forbid",
        allow_inf_nan=False,
        frozen=True,
        strict=True,
        json_schema_serialization_defaults_required=True,
    )


# -- controllers ------------------------------------------------------------------
class PredefinedController(Model):
    """The plant's predefined controller."""

    kind: Literal["predefined"]


class Complex(Model):
    re: float
    im: float


class StateFeedbackController(Model):
    """u = K (x_ref − x̂): one gain per state; or u = Nr r − K x̂ with a reference gain.
    x̂: the true state, velocity filters, or a Luenberger observer (gain L, or placed at
    observer_poles)."""

    kind: Literal["state_feedback"]
    K: list[Finite] = Field(min_length=1, max_length=64)
    estimate: Literal["true_state", "velocity_filters", "observer"] = "velocity_filters"
    Nr: Finite | None = Field(None, description="reference gain (default: the reference state's K)")
    L: list[list[Finite]] | None = Field(
        None, max_length=64, description="observer gain: a row per state, a column per output"
    )
    observer_poles: list[Complex] | None = Field(
        None, max_length=64, description="where to place the observer's poles (one per state)"
    )


class PIDController(Model):
    """C(s) = Kp + Ki/s + Kd s/(Tf s + 1), Tf = Kd/(N Kp), on e = r − y."""

    kind: Literal["pid"]
    Kp: Finite
    Ki: Finite = 0.0
    Kd: Finite = 0.0
    N: Finite = Field(10.0, gt=0)
    Tt: Finite | None = Field(None, gt=0, description="anti-windup tracking time (s)")
    b: Finite = Field(1.0, description="setpoint weight of the proportional term")
    c: Finite = Field(1.0, description="setpoint weight of the derivative term")


class LTIControllerModel(Model):
    """Any SISO LTI controller on e = r − y: num/den or A, B, C, D; dt = null: continuous."""

    kind: Literal["lti"]
    num: list[Finite] | None = Field(None, max_length=64)
    den: list[Finite] | None = Field(None, max_length=64)
    A: list[list[Finite]] | None = Field(None, max_length=64)
    B: list[list[Finite]] | None = Field(None, max_length=64)
    C: list[list[Finite]] | None = Field(None, max_length=1)
    D: list[list[Finite]] | None = Field(None, max_length=1)
    dt: Finite | None = Field(None, gt=0)
    ff_num: list[Finite] | None = Field(
        None, max_length=64, description="feed-forward from r to u, added: numerator"
    )
    ff_den: list[Finite] | None = Field(None, max_length=64, description="and denominator")
    B_r: list[list[Finite]] | None = Field(
        None,
        max_length=64,
        description="with A, B, C, D: the reference's own input to the states "
        "(x' = A x + B e + B_r r; two degrees of freedom)",
    )
    D_r: list[list[Finite]] | None = Field(
        None, max_length=1, description="and to u (u = C x + D e + D_r r)"
    )


class OpenLoopController(Model):
    """No feedback: the signal is the plant input (V)."""

    kind: Literal["open_loop"]


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
    kind: Literal["step"]
    amplitude: Finite
    t0: Finite = Field(0.0, ge=0)
    offset: Finite = 0.0


class SquareSignal(Model):
    kind: Literal["square"]
    amplitude: Finite
    period: Finite = Field(gt=0)
    offset: Finite = 0.0
    duty: Finite = Field(0.5, gt=0, le=1)


class SineSignal(Model):
    kind: Literal["sine"]
    amplitude: Finite
    frequency: Finite = Field(gt=0, description="Hz")
    phase: Finite = 0.0
    offset: Finite = 0.0


class ChirpSignal(Model):
    kind: Literal["chirp"]
    amplitude: Finite
    f0: Finite = Field(ge=0)
    f1: Finite = Field(gt=0)
    sweep: Finite = Field(gt=0)
    offset: Finite = 0.0


class PRBSSignal(Model):
    kind: Literal["prbs"]
    amplitude: Finite
    order: int = Field(10, ge=3, le=20)
    band: Finite = Field(1.0, ge=PRBS_MIN_BAND, le=1)
    offset: Finite = 0.0


class SamplesSignal(Model):
    kind: Literal["samples"]
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
    controller: Controller = PredefinedController(kind="predefined")
    signal: Signal | None = None
    excitation: Signal | None = None
    excitation_at: Literal["reference", "input"] = "input"
    duration: Finite | None = Field(None, gt=0, description="s")
    pace: Literal["realtime", "fast"] = "realtime"
    noise: bool | None = Field(
        None,
        description="the plant's sensor noise (white, GET /plants/{id} sensors.noise_std). "
        "Default: on for identification runs and whenever a seed is given, else off",
    )
    seed: int | None = Field(
        None,
        ge=0,
        le=2**63 - 1,
        description="sensor noise seed (default with noise on: a random one; the recorded "
        "request holds it, so the run can be repeated)",
    )
    quantize: bool | None = Field(
        None,
        description="round the outputs to the sensors' resolution (sensors.quantum). "
        "Default: on for identification runs, else off",
    )
    saturate: bool | None = None
    Ts: Finite | None = Field(None, gt=0)
    x0: list[Finite] | None = Field(None, max_length=64)
    private: bool = Field(
        False,
        description="only its owner and instructors may see it (default: anyone with its link)",
    )
    controller_id: str | None = Field(
        None,
        min_length=1,
        max_length=64,
        description="an uploaded controller (POST /controllers) to run; its law replaces "
        "`controller`, and the recorded request holds both",
    )


class ChannelInfo(Model):
    name: str
    unit: str


class RecordingParamChange(Model):
    k: int = Field(description="the first sample with the new parameters")
    t: float = Field(description="its time (s)")
    params: dict[str, Any]


class RecordingOut(Model):
    """A recording downloaded as JSON (``GET /runs/{id}/data?format=json``): the CSV's
    header lines as ``header``, the time column ``t`` (s) and one column per channel in
    ``data``, in SI units as ``channels`` says."""

    header: dict[str, str]
    Ts: float
    k0: int = Field(description="the index of the first sample")
    channels: list[ChannelInfo]
    t: list[float]
    data: dict[str, list[float]]
    param_changes: list[RecordingParamChange]


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
    error: str | None = Field(
        description="why it failed, stopped early (who stopped it) or was interrupted; "
        "while it is paused, who paused it or why"
    )
    compute: ComputeTimes | None = Field(
        None, description="a Python controller's time per step over the run, once it ended"
    )
    url: str
    owner: str = Field(description="who started it, as others see them (guest 3f2a, a name)")
    private: bool
    mine: bool = Field(description="the caller started it")
    can_control: bool = Field(
        description="the caller may pause, resume, stop, change and delete it (its owner or "
        "an instructor)"
    )


class RunInfo(RunSummaryInfo):
    frame_samples: int
    stream_url: str
    data_url: str
    request: dict[str, Any]
    param_changes: list[ParamChangeInfo] = []


# -- who may do what ------------------------------------------------------------------
class Me(Model):
    """Who the server takes the caller for."""

    id: str | None = Field(description="what owned objects record (null: no identity)")
    name: str = Field(description="as others see it")
    role: Literal["student", "instructor"]
    via: Literal["cookie", "session", "token", "none"] = Field(
        description="cookie: the browser's anonymous identity; session: an instructor "
        "signed in; token: an API token"
    )
    account: str | None = Field(description="the instructor account's name (null: none)")
    sign_in: bool = Field(description="this server has instructor accounts to sign in to")


class SignIn(Model):
    name: str = Field(min_length=1, max_length=40)
    password: str = Field(min_length=1, max_length=200)


class TokenCreate(Model):
    name: str = Field(min_length=1, max_length=60, description="what it is for")


class TokenInfo(Model):
    id: str
    name: str
    created_at: float
    last_used: float | None


class TokenCreated(TokenInfo):
    token: str = Field(description="send as Authorization: Bearer <token>; shown once, never again")


class DemoPin(Model):
    run_id: str = Field(min_length=1, max_length=64)


class DemoInfo(Model):
    """The class demo an instructor pinned (``run`` null: none)."""

    run: RunSummaryInfo | None
    pinned_by: str | None = None
    pinned_at: float | None = None


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


class ServerStatus(Model):
    live_runs: int
    watchers: int = Field(description="websocket watchers connected, all runs")
    stepper: StepperTiming
    engine: EngineInfo
    store: StoreInfo
    ident: JobsInfo
    uploads: UploadsInfo


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


class _Change(Model):
    """New controller gains and/or reference: at least one; an omitted one stays as it is
    (``null`` is not a value here: the schema and the server both refuse it)."""

    controller: Controller | SkipJsonSchema[None] = None
    controller_id: Annotated[str, Field(min_length=1, max_length=64)] | SkipJsonSchema[None] = (
        Field(
            None, description="an uploaded controller (POST /controllers) instead of `controller`"
        )
    )
    signal: Signal | SkipJsonSchema[None] = None

    @field_validator("controller", "controller_id", "signal", mode="before")
    @classmethod
    def _given(cls, value: Any) -> Any:
        if value is None:
            raise ValueError("omit it to keep the current one")
        return value


class ParamsUpdate(_Change):
    """New controller gains and/or reference, applied from the next sample (at least one;
    an omitted one, or one equal to what the run uses, stays as it is)."""

    model_config = ConfigDict(**Model.model_config, json_schema_extra={"minProperties": 1})


class ParamDiff(Model):
    """One value a change altered: ``field`` as in the request (``signal.amplitude``,
    ``controller.K.1``), values in SI units (``null``: not set)."""

    field: str
    before: float | int | str | bool | None
    after: float | int | str | bool | None


class ParamsApplied(Model):
    k: int = Field(description="first sample computed with the new parameters")
    t: float
    changed: list[ParamDiff] = Field(
        [],
        description="what the change altered, field by field; empty when the values given "
        "are those the run uses (nothing is then applied or recorded, and k is the sample "
        "the run has reached)",
    )


# -- plants, analysis, design ------------------------------------------------------
# -- uploaded controllers ----------------------------------------------------------------
class ControllerUpload(Model):
    """A controller file (docs/controllers.md): TOML, JSON or Python as text, .mat or .npz as
    base64."""

    plant: str = Field(min_length=1, max_length=64)
    format: Literal["toml", "json", "mat", "npz", "py"]
    content: str = Field(
        min_length=1, max_length=90_000, description="the file: text, or base64 for mat/npz"
    )
    name: str | None = Field(
        None,
        max_length=80,
        description="default: the `name` in the file, else '<plant> <format> controller'",
    )


class ComputeTimes(Model):
    """A Python controller's time per step: its own compute time inside the sandbox
    (median, p99, max) and the round trip a run waits for, in µs. A simulation waits for
    a late answer (its samples never depend on the machine's load); the rig will hold
    the last u."""

    steps: int
    median_us: float
    p99_us: float
    max_us: float
    round_trip_median_us: float
    round_trip_p99_us: float
    misses: int = Field(description="steps answered after the deadline")
    slow: int = Field(description="steps whose own compute time passed the deadline")


class ControllerReportOut(Model):
    """The report on the plant's linear model, or for a Python controller on trial runs in
    its sandbox (docs/controllers.md)."""

    stable: bool
    domain: Literal["s", "z", "trial"] = Field(
        description="z: a discrete controller, poles in z; trial: a Python controller, "
        "checked by trial runs on the model (no poles or margins)"
    )
    poles: list[Complex]
    gain_margin_db: float | None
    phase_margin_deg: float | None
    peak_u: float | None = Field(description="V, for a step of the default reference")
    u_max: float
    step_amplitude: float
    rig_ready: bool
    problems: list[str]
    warnings: list[str]
    compute: ComputeTimes | None = Field(None, description="a Python controller's, in its trial")
    trial: str | None = Field(None, description="what the trial ran (a Python controller)")


class UploadedController(Model):
    """A controller a user uploaded, with the law read from it and its report."""

    id: str
    plant: str
    name: str
    format: str
    owner: str
    mine: bool
    created_at: float
    controller: Controller | None = Field(
        description="the law read from the file (none for a Python controller: its code is it)"
    )
    code: str | None = Field(
        None, description="a Python controller's source (not in the list: GET it by id)"
    )
    report: ControllerReportOut
    url: str


class UploadedControllerList(Model):
    controllers: list[UploadedController]


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
    default_x0: list[float] | None = Field(
        None,
        description="the absolute initial state the analysis experiment starts from "
        "(null: the operating point)",
    )
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


class StepCut(Model):
    """Where a response left the plant's range (the linear model's validity): it ends
    with the first sample outside."""

    output: str
    t: float = Field(description="s, the first sample outside")
    low: float = Field(description="the range, absolute, in the output's SI unit")
    high: float


class StepOut(Model):
    plant: str
    loop: Literal["open", "closed"]
    t: list[float]
    outputs: dict[str, list[float]]
    u: list[float]
    info: StepInfoOut | None = Field(description="of the reference output (closed loop)")
    poles: list[Complex]
    verdict: str
    cut: StepCut | None = Field(
        None, description="the response is cut where an output left the plant's range"
    )


class LQRRequest(Model):
    Q: (
        Annotated[list[Finite], Field(min_length=1, max_length=64)]
        | Annotated[
            list[Annotated[list[Finite], Field(min_length=1, max_length=64)]],
            Field(min_length=1, max_length=64),
        ]
    ) = Field(description="diagonal or full matrix")
    R: Finite | Annotated[list[list[Finite]], Field(min_length=1, max_length=64)] = 1.0


class PlaceRequest(Model):
    poles: list[Complex] = Field(min_length=1, max_length=64)


class DesignOut(Model):
    plant: str
    method: Literal["lqr", "place"]
    K: list[float]
    closed_loop_poles: list[Complex]
    convention: str = "u = K (x_ref - x)"


# -- errors --------------------------------------------------------------------------
class FieldError(Model):
    field: str
    message: str


class ErrorDetail(Model):
    code: Literal[
        "invalid",
        "not_found",
        "conflict",
        "too_many",
        "too_large",
        "unavailable",
        "forbidden",
        "unauthorized",
        "unsupported_media_type",
        "timeout",
    ]
    message: str
    field: str | None = None
    errors: list[FieldError] = []


class ErrorBody(Model):
    error: ErrorDetail


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

    source: Literal["run"]
    run: str = Field(min_length=1, max_length=64)
    input: Channels = ["u"]
    output: Channels | None = Field(None, description="default: the plant's reference output")
    t_from: Finite | None = Field(None, ge=0, description="s")
    t_to: Finite | None = Field(None, gt=0, description="s")


class FileData(Model):
    """An uploaded table: an E-Lab CSV/JSON download, or plain numeric columns
    (comma- or whitespace-separated; unnamed columns are c1, c2, …)."""

    source: Literal["file"]
    format: Literal["csv", "json"] = "csv"
    name: str = Field("upload", max_length=200)
    text: str = Field(min_length=1, description="the file's content")
    input: Channels
    output: Channels
    Ts: Finite | None = Field(None, gt=0, description="s; default: from the file")


Order = Annotated[int, Field(ge=1, le=50)]  # a polynomial's number of coefficients
Lags = Annotated[int, Field(ge=0, le=50)]  # na (none allowed) and the delay nk


class ArxSpec(Model):
    kind: Literal["arx"]
    na: Lags
    nb: Order
    nk: Lags = 1


class ArmaxSpec(Model):
    kind: Literal["armax"]
    na: Lags
    nb: Order
    nc: Order
    nk: Lags = 1


class OeSpec(Model):
    kind: Literal["oe"]
    nb: Order
    nf: Order
    nk: Lags = 1


class N4sidSpec(Model):
    kind: Literal["n4sid"]
    order: int = Field(0, ge=0, le=99, description="0: chosen from the singular values")
    horizon: int = Field(0, ge=0, le=100, description="block rows; 0: the default")


ModelSpec = Annotated[ArxSpec | ArmaxSpec | OeSpec | N4sidSpec, Field(discriminator="kind")]


class ArxSearch(Model):
    na: Span = [1, 10]
    nb: Span = [1, 10]
    nk: Span = [1, 10]


IdentSource = Annotated[RunData | FileData, Field(discriminator="source")]


class IdentRequest(Model):
    """Identification on a run's data or an uploaded table. ``split``: the estimation
    share (the first part); the rest validates. Or ``validation``: a separate record to
    validate on, given as ``data`` is, with the same channels and sample time; ``data``
    then all estimates and ``split`` is not used. Both records together are within the
    body's limit (``ELAB_MAX_UPLOAD``) and 2,000,000 samples. Send ``Accept:
    application/x-ndjson`` to receive progress lines before the result."""

    data: IdentSource
    validation: IdentSource | None = Field(
        None,
        description="a separate validation record (the same channels and sample time); "
        "with detrend 'mean', the estimation record's means are removed from both",
    )
    detrend: Literal["mean", "linear", "none"] = "mean"
    split: Finite = Field(0.5, gt=0, lt=1, description="not used with a validation record")
    correlation: bool = True
    max_lag: int = Field(30, ge=1, le=500)
    spectral: bool = True
    sine_hz: Finite | None = Field(None, gt=0, description="Hz; default: a run's sine signal")
    arx_search: ArxSearch | None = None
    n4sid_orders: Span | None = None
    horizon: int | None = Field(None, ge=2, le=100)
    models: list[ModelSpec] = Field([], max_length=10)


def _finite_or_none(value: Any) -> Any:
    return None if isinstance(value, float) and not math.isfinite(value) else value


#: A result number: ``null`` where it is not finite (a fit of −∞ on a constant output).
Num = Annotated[float | None, BeforeValidator(_finite_or_none)]
Matrix = list[list[float]]


class IdentDataOut(Model):
    """The data as analysed (detrended), thinned to ≤ 5000 points per series: every
    ``step``-th sample; the first ``estimation`` samples estimate, the rest validate:
    the rest of the data (``validation`` "split"), or a separate record (``validation``
    "record"), whose samples follow the estimation record's on the time axis."""

    N: int
    Ts: float
    estimation: int
    validation: Literal["split", "record"] = "split"
    step: int
    trend: str
    t: list[float]
    u: list[list[float]] = Field(description="[input][sample]")
    y: list[list[float]] = Field(description="[output][sample]")
    input_names: list[str]
    output_names: list[str]
    input_units: list[str]
    output_units: list[str]


class CorrelationOut(Model):
    """Impulse response by correlation analysis, with its ±3σ band and the delay."""

    lags: list[int]
    impulse: list[Num]
    band: list[Num]
    delay: int | None = Field(description="samples; null: none is evident")
    Ts: float


class SpectralOut(Model):
    """Frequency response by spectral analysis (Blackman–Tukey)."""

    omega: list[float] = Field(description="rad/s")
    magnitude: list[Num]
    phase_deg: list[Num]
    noise_spectrum: list[Num]
    window: int


class SineOut(Model):
    frequency_hz: float
    omega: float
    magnitude: Num
    phase_deg: Num
    periods_used: int
    samples_used: int


class ArxSearchOut(Model):
    """One row per structure: ``[na, nb, nk, validation loss]``; the best by loss, AIC, MDL.
    With several outputs, one search per output (``output`` names it), each structure's
    nb and nk applying to every input."""

    output: str | None = None
    rows: list[list[Num]]
    best: list[int]
    aic: list[int]
    mdl: list[int]


class OrderRow(Model):
    order: int
    loss: Num
    mdl: Num
    aic: Num


class N4sidOrdersOut(Model):
    horizon: int
    best: int
    reason: str = Field(description="why that order: a gap in the singular values, or MDL")
    orders: list[OrderRow]
    singular_values: list[Num]


class AnalysesOut(Model):
    """Those asked for (and possible: the first four need one input and one output)."""

    correlation: CorrelationOut | None = None
    spectral: SpectralOut | None = None
    sine: SineOut | None = None
    arx_search: ArxSearchOut | None = None
    arx_search_outputs: list[ArxSearchOut] | None = None
    n4sid_orders: N4sidOrdersOut | None = None


class FitOut(Model):
    """Fit % per output: on the validation set simulated from a zero initial state (the
    published figures' convention), from the best initial state, and one step ahead; on the
    estimation set simulated from the best initial state. The headline is the validation
    simulation fit that means something for the model: from the estimated initial state
    when a mode does not decay within the validation record (integrating, unstable or
    slower than the record), else from zero."""

    validation_simulation: list[Num]
    validation_simulation_x0: list[Num]
    validation_one_step: list[Num]
    estimation_simulation: list[Num]
    headline: list[Num]
    headline_x0: Literal["zero", "estimated"]
    headline_why: str


class StateSpaceOut(Model):
    """The innovations form x⁺ = A x + B u + K e, y = C x + D u + e (discrete, Ts)."""

    A: Matrix
    B: Matrix
    C: Matrix
    D: Matrix
    K: Matrix
    Ts: float


class TransferFunctionOut(Model):
    num: list[float] = Field(description="powers of z, highest first")
    den: list[float]


class ContinuousOut(Model):
    A: Matrix
    B: Matrix
    C: Matrix
    D: Matrix


class ResidualsOut(Model):
    lags: list[int]
    autocorrelation: list[Num]
    cross_lags: list[int]
    cross_correlation: list[Num]
    bound: Num
    white: bool
    independent: bool


class IdentModelOut(Model):
    name: str
    kind: Literal["arx", "armax", "oe", "n4sid"]
    orders: dict[str, int]
    parameters: dict[str, list[Num] | list[list[Num]] | bool | int | Num | str | dict[str, Num]] = (
        Field(
            description="the model's own parameters (polynomials with their standard deviations, "
            "loss, FPE, AIC; for ARMAX and OE the winning start and every start's loss "
            "(`start`, `start_losses`), for ARMAX whether C's roots sit at the 0.99 margin; for "
            "n4sid the singular values, x0, how B and D were had ('subspace' or 'simulation'), "
            "whether A was stabilised and which poles were reflected ([|z| before, after] each) "
            "with the estimation fits as estimated and reflected, and how K was had: 'riccati' "
            "or 'none' (an output-error predictor)"
        )
    )
    fit: FitOut
    noise_variance: list[list[Num]]
    poles: list[list[float]] = Field(description="[re, im] in the z plane")
    stable: bool
    ss: StateSpaceOut
    tf: list[list[TransferFunctionOut]] = Field(description="[output][input]")
    continuous: ContinuousOut | None = Field(
        description="by the inverse zero-order hold; null where no real one exists"
    )
    simulated: list[list[Num]] = Field(
        description="[output][sample] on the validation set, from a zero initial state; "
        "null where the simulation overflowed (a model that diverges)"
    )
    simulated_x0: list[list[Num]] = Field(description="the same from the estimated state")
    one_step: list[list[Num]]
    residuals: ResidualsOut | None = None


class IdentOut(Model):
    """Every result of an identification (docs/identification.md)."""

    data: IdentDataOut
    analyses: AnalysesOut
    models: list[IdentModelOut]
    notes: list[str]


class IdentProgress(Model):
    stage: str
    done: float = Field(ge=0, le=1)


class IdentLine(Model):
    """One line of the NDJSON answer: progress while it works, then the result or an error."""

    progress: IdentProgress | None = None
    result: IdentOut | None = None
    error: ErrorDetail | None = None


# -- identified models and design on them (api/models.py, api/designs.py) -------------
MAX_MODEL_STATES = 20  # elab.design.model.MAX_STATES
ModelNumber = Annotated[Finite, Field(ge=-1e12, le=1e12)]
ModelRow = Annotated[list[ModelNumber], Field(min_length=1, max_length=MAX_MODEL_STATES)]
ModelMatrix = Annotated[list[ModelRow], Field(min_length=1, max_length=MAX_MODEL_STATES)]


class ModelChannel(Model):
    name: str = Field(min_length=1, max_length=40)
    unit: str = Field("", max_length=20, description="SI: rad, m, V, …")


class ModelCreate(Model):
    """A discrete model to keep, as identification gives it (``POST /ident``: a model's
    ``ss`` and the data's names): x⁺ = A x + B u, y = C x + D u at sample time Ts, one
    input, at most 20 states and 8 outputs."""

    plant: str = Field(min_length=1, max_length=64, description="the plant it models")
    name: str = Field(min_length=1, max_length=80)
    Ts: Finite = Field(ge=1e-6, le=3600, description="s")
    A: ModelMatrix
    B: ModelMatrix = Field(description="n × 1")
    C: ModelMatrix = Field(description="one row per output, n columns")
    D: ModelMatrix = Field(description="one row per output, one column")
    input: ModelChannel = ModelChannel(name="u", unit="V")
    outputs: list[ModelChannel] = Field(min_length=1, max_length=8)
    source: str = Field("", max_length=200, description="where it came from: a run, a file")
    kind: str = Field("", max_length=20, description="arx, armax, oe, n4sid, …")
    fit: list[Finite | None] = Field(
        [], max_length=8, description="validation fit per output (%), as identification said"
    )


class IdentifiedModel(Model):
    """A kept model: anyone with its id may read it and design on it; its owner or an
    instructor may delete it."""

    id: str
    plant: str
    name: str
    owner: str = Field(description="who kept it, as others see them")
    mine: bool
    can_delete: bool
    created_at: float
    Ts: float
    A: Matrix
    B: Matrix
    C: Matrix
    D: Matrix
    input: ModelChannel
    outputs: list[ModelChannel]
    source: str
    kind: str
    fit: list[Num]
    poles: list[Complex] = Field(description="z")
    poles_s: list[Complex] | None = Field(
        description="continuous equivalents ln(z)/Ts (null: a pole at z ≤ 0 has none)"
    )
    stable: bool
    tf: list[TransferFunctionOut] = Field(description="per output, powers of z")
    not_runnable: str | None = Field(
        description="why a design on it cannot run on the plant (null: it can)"
    )
    url: str
    page: str = Field(description="the design page for it (a shareable link)")


class IdentifiedModelList(Model):
    models: list[IdentifiedModel]


class _ModelDesign(Model):
    domain: Literal["discrete", "continuous"] = Field(
        "discrete",
        description="discrete: on the model as identified; continuous: its ZOH inverse",
    )
    amplitude: Finite | None = Field(
        None,
        description="height of the reference step for the response and the peak u (the "
        "output's SI unit; default: the plant's default reference amplitude)",
    )
    T: Finite | None = Field(None, gt=0, le=3600, description="horizon of the step (s)")


class _ObservedDesign(_ModelDesign):
    observer_poles: list[Complex] | None = Field(
        None,
        max_length=MAX_MODEL_STATES,
        description="one per state (s or z); default: the loop's, three times faster",
    )


class ModelLQR(_ObservedDesign):
    """LQR: Q (diagonal or full) or an output weight q (Q = q Cᵣᵀ Cᵣ; neither: Bryson's
    rule q = (0.8 u_max / amplitude)², 80 % of the actuator's limit for the step), and R."""

    method: Literal["lqr"]
    Q: (
        Annotated[list[Finite], Field(min_length=1, max_length=MAX_MODEL_STATES)]
        | ModelMatrix
        | None
    ) = None
    output_weight: Finite | None = Field(None, gt=0)
    R: Finite = Field(1.0, gt=0)


class ModelPlace(_ObservedDesign):
    method: Literal["place"]
    poles: list[Complex] = Field(min_length=1, max_length=MAX_MODEL_STATES)


class ModelGain(_ObservedDesign):
    """A gain typed by hand: one per model state."""

    method: Literal["gain"]
    K: list[ModelNumber] = Field(min_length=1, max_length=MAX_MODEL_STATES)


class ModelPID(_ModelDesign):
    """A PID on the error of the reference output (derivative filter N)."""

    method: Literal["pid"]
    Kp: Finite
    Ki: Finite = 0.0
    Kd: Finite = 0.0
    N: Finite = Field(10.0, gt=0)


class ModelDesignRequest(
    RootModel[
        Annotated[ModelLQR | ModelPlace | ModelGain | ModelPID, Field(discriminator="method")]
    ]
):
    """One design on a model: ``method`` lqr, place, gain (K typed by hand) or pid."""


class MarginsOut(Model):
    """Of the loop broken at the plant input (null: no crossover)."""

    gain_margin_db: Num
    phase_margin_deg: Num
    gain_crossover: Num = Field(description="rad/s")
    phase_crossover: Num = Field(description="rad/s")


class RootLocusOut(Model):
    """Closed-loop poles as the loop gain k is scaled (k = 1: as designed): branch i at
    ``gains[j]`` is (re[i][j], im[i][j]) in s or z."""

    domain: Literal["s", "z"]
    gains: list[float]
    re: list[list[Num]]
    im: list[list[Num]]
    poles: list[Complex] = Field(description="the open loop's (k = 0)")
    zeros: list[Complex]


class LoopOut(Model):
    """What the design page shows of a loop besides its step: poles, verdict, margins, root
    locus, and the peak |u| a reference step of ``amplitude`` asks (null: unstable)."""

    plant: str
    closed_loop_poles: list[Complex]
    verdict: Literal["asymptotically stable", "marginally stable", "unstable"]
    reason: str
    margins: MarginsOut
    root_locus: RootLocusOut
    amplitude: float
    peak_u: Num
    u_max: float
    saturates: bool = Field(description="the peak passes the actuator limit")


class ModelDesignOut(LoopOut):
    """A design on a kept model. ``controller`` is what ``POST /runs`` takes (with ``Ts`` =
    ``run_Ts``) and ``POST /plants/{plant_id}/controller-file`` writes; null when the
    model's outputs are not the plant's (``not_runnable`` says why)."""

    model: str
    method: Literal["lqr", "place", "gain", "pid"]
    domain: Literal["discrete", "continuous"]
    K: list[float] | None
    Nr: float | None = Field(description="reference gain: u = Nr r − K x̂")
    L: list[list[float]] | None = Field(description="observer gain, states × outputs")
    observer_poles: list[Complex] | None
    step: StepOut
    controller: Controller | None
    run_Ts: float | None = Field(description="the sample time a run needs (null: the plant's)")
    not_runnable: str | None


class LoopRequest(Model):
    """A controller for a plant's loop (LoopOut)."""

    controller: Controller
    amplitude: Finite | None = Field(
        None, description="reference step; default: the plant's default amplitude"
    )


class ControllerFileRequest(Model):
    """A controller as a file to download (what an upload reads back)."""

    controller: Controller
    format: Literal["toml", "json", "mat", "npz", "py"] = "toml"
    name: str | None = Field(None, max_length=80)


# -- websocket messages ------------------------------------------------------------
class CloseCode(IntEnum):
    """Why the server closes a stream (the close frame's reason says more): 4400 the
    request was wrong (no ``elab.v1`` subprotocol, a bad ``from_seq``), 4404 no such run,
    4429 the identity has ``ELAB_MAX_STREAMS_PER_IDENTITY`` streams open: a client should
    not reconnect after these. 4408: the client stopped reading while it kept sending (its
    answers piled up); it may reconnect."""

    BAD_REQUEST = 4400
    NOT_FOUND = 4404
    NOT_READING = 4408
    TOO_MANY = 4429


class StreamClose(Model):
    """How the server ends a stream it refuses: the websocket close frame's code and reason."""

    code: CloseCode
    reason: str = Field(max_length=123)


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


class SetParams(_Change):
    """As ``POST /runs/{id}/params``: new gains and/or reference (at least one). Its
    ``params`` notice holds the parts that changed; a change that changes nothing is not
    applied and has no notice."""

    model_config = ConfigDict(**Model.model_config, json_schema_extra={"minProperties": 2})
    type: Literal["set_params"]


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
