"""Identification: the request (data, analyses, model structures) and every result."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from elab.api.schemas.base import Finite, Matrix, Model, Num
from elab.api.schemas.errors import ErrorDetail

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
    reference: Channels | None = Field(
        None,
        description="for two_stage: the signals that drove the loop, recorded channels or "
        "'excitation' (the run's input excitation as it was requested); default: r and, "
        "if the run had one at the input, the excitation",
    )


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
    reference: Channels | None = Field(
        None, description="for two_stage: the columns of the signals that drove the loop"
    )


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


class LinkSpec(Model):
    """The rotary flexible link's physics (input u; outputs θ then α, in rad; detrend
    none): docs/identification.md."""

    kind: Literal["link"]


ModelSpec = Annotated[
    ArxSpec | ArmaxSpec | OeSpec | N4sidSpec | LinkSpec, Field(discriminator="kind")
]


class ArxSearch(Model):
    na: Span = [1, 10]
    nb: Span = [1, 10]
    nk: Span = [1, 10]


IdentSource = Annotated[RunData | FileData, Field(discriminator="source")]


Coefficients = Annotated[list[Finite], Field(min_length=1, max_length=50)]


class IndirectSpec(Model):
    """The loop's known controller for the indirect method, at the data's sample time:
    u = w − C(q) y with C(q) = num(q⁻¹) / den(q⁻¹); ``u = r − 0.6 y`` is ``num [0.6]``,
    ``den [1]``."""

    num: Coefficients
    den: Coefficients


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
    detrend: Literal["mean", "linear", "none", "operating_point"] = Field(
        "mean",
        description="'mean' and 'linear' take each part's own trend off; 'none' keeps the "
        "data as recorded; 'operating_point' takes the run's plant's rest off every "
        "channel (a run's data only: a file's rest is not known), which keeps an "
        "integrating plant's record as it is and takes off offsets like the upright "
        "pendulum's π",
    )
    split: Finite = Field(0.5, gt=0, lt=1, description="not used with a validation record")
    correlation: bool = True
    max_lag: int = Field(30, ge=1, le=500)
    spectral: bool = True
    sine_hz: Finite | None = Field(None, gt=0, description="Hz; default: a run's sine signal")
    arx_search: ArxSearch | None = None
    n4sid_orders: Span | None = None
    horizon: int | None = Field(None, ge=2, le=100)
    decimate: int = Field(
        1,
        ge=1,
        le=100,
        description="keep every n-th sample after an anti-aliasing filter (1: all); the "
        "analysis runs at n·Ts",
    )
    models: list[ModelSpec] = Field([], max_length=10)
    two_stage: int | None = Field(
        None,
        ge=1,
        le=1000,
        description="closed loop: the two-stage method with a first stage of this many "
        "taps (the estimation part's input replaced by its FIR prediction from "
        "data.reference; validation reads the measured input); null: the direct method",
    )
    indirect: IndirectSpec | None = Field(
        None,
        description="closed loop: the indirect method with this known controller (one "
        "input, one output, every sample): the models are fitted to the loop from "
        "w = u + C y to y and turned into the plant with C; null: the direct method",
    )


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
    holdout: Num = Field(
        description="fit % of the estimation record's last third simulated from rest by "
        "the model of its first two thirds (null: not checked)"
    )


class N4sidOrdersOut(Model):
    horizon: int
    best: int
    reason: str = Field(
        description="why that order: a gap in the singular values, the best fit of the "
        "record's last third, or MDL"
    )
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


class VerdictOut(Model):
    """A verdict in plain words (docs/identification.md, "Verdicts")."""

    topic: str = Field(
        description="on the data: feedback, excitation, noise, quantisation, delay, length, "
        "order_search, two_stage; on a model: stability, integrator, fit, residuals, order, "
        "physics",
    )
    level: Literal["good", "caution", "poor"]
    finding: str
    advice: str | None = Field(description="what to change; null when nothing needs to")


class IdentModelOut(Model):
    name: str
    kind: Literal["arx", "armax", "oe", "n4sid", "link"]
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
    verdicts: list[VerdictOut] = Field(default_factory=list)
    level: Literal["good", "caution", "poor"] = Field(
        default="good",
        description="its worst verdict's: 'poor' is not to be designed on as it is",
    )


class IdentOut(Model):
    """Every result of an identification (docs/identification.md)."""

    data: IdentDataOut
    analyses: AnalysesOut
    models: list[IdentModelOut]
    notes: list[str]
    verdicts: list[VerdictOut] = Field(
        default_factory=list, description="on the data (and the ARX order search)"
    )


class IdentProgress(Model):
    stage: str
    done: float = Field(ge=0, le=1)


class IdentLine(Model):
    """One line of the NDJSON answer: progress while it works, then the result or an error."""

    progress: IdentProgress | None = None
    result: IdentOut | None = None
    error: ErrorDetail | None = None
