"""Plants and their linear models: details, analysis, Bode, step responses and the
LQR and pole-placement designs on a plant."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from elab.api.schemas.base import Complex, Finite, Model
from elab.api.schemas.laws import Controller
from elab.api.schemas.signals import Signal


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


class IdentDefaultsInfo(Model):
    models: str = Field(description="the CLI's syntax: arx:4,4,1; n4sid:4")
    decimate: int
    why: str


class LessonStepInfo(Model):
    """One run of the plant's lesson, ready to start: the fields of ``POST /runs`` it
    sets (with ``plant`` and ``experiment`` "analysis")."""

    title: str
    text: str
    controller: Controller
    signal: Signal
    duration: float
    x0: list[float] | None = Field(
        None, description="the absolute initial state (null: the operating point)"
    )


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
    integrating: bool = Field(
        False,
        description="a pole at s = 0: an output integrates the input (identification "
        "keeps its runs' data as recorded by default: removing the input's mean would "
        "add a ramp the plant never made)",
    )
    identification: IdentDefaultsInfo = Field(
        description="what the identification page proposes for this plant's runs, and why"
    )
    lesson: list[LessonStepInfo] = Field(
        default_factory=list,
        description="the runs a presenter steps through with one key (the chapter's: the "
        "plant alone, an arbitrary gain, the designed controller)",
    )
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
