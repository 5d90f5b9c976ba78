"""Runs: the request that starts one, what a run looks like in a list and alone, its
recording as JSON, and live changes of its gains and reference."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import ConfigDict, Field, field_validator
from pydantic.json_schema import SkipJsonSchema

from elab.api.schemas.base import Finite, Model
from elab.api.schemas.controllers import ComputeTimes
from elab.api.schemas.laws import Controller, PredefinedController
from elab.api.schemas.plants import StepInfoOut
from elab.api.schemas.signals import Signal


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
    ``data``, in SI units as ``channels`` says; ``null`` where nobody measured (a sample
    a rig dropped: its reference and the voltage held are there, its measurements not)."""

    header: dict[str, str]
    Ts: float
    k0: int = Field(description="the index of the first sample")
    channels: list[ChannelInfo]
    t: list[float]
    data: dict[str, list[float | None]]
    param_changes: list[RecordingParamChange]


class ParamChangeInfo(Model):
    k: int
    t: float
    at: float
    params: dict[str, Any]


RunStateName = Literal[
    "created", "running", "paused", "finished", "stopped", "failed", "interrupted"
]


class OutcomeMark(Model):
    """Something about how a run went that its state alone would hide, from the sample
    ``k`` (at ``t`` s) on: ``left_range`` (an output left its model's valid range),
    ``saturated`` (the input sat at the actuator's limit), ``beyond_actuator`` (saturation
    off and |u| above the actuator's limit), ``ran_away`` (a closed loop's output ended far
    from the reference); ``text`` says it with the numbers."""

    kind: Literal["left_range", "saturated", "beyond_actuator", "ran_away"]
    k: int
    t: float
    text: str


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
    outcome: list[OutcomeMark] | None = Field(
        None,
        description="how it went beyond its status, once it ended ([]: nothing to say; "
        "null: not known, a live run or one recorded before outcomes were kept)",
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


class PredictedChannel(Model):
    """One predicted column: ``values[k]`` is sample ``k`` (SI units, as the recording)."""

    name: str
    unit: str
    label: str
    values: list[float]


class PredictionGap(Model):
    """How far the recording is from the prediction on one channel, over the samples
    compared: root mean square and largest ``|run − prediction|`` (the channel's unit), and
    when the largest happened (s)."""

    name: str
    unit: str
    rms: float
    max_abs: float
    t_max: float


class PredictionStep(Model):
    """One step of the recorded reference (constant from ``t`` for ``span`` s; the first
    20 steps) and the reference output's response to it in the run and in the
    prediction, with the design page's characteristics (``StepInfoOut``: times in s from
    the step, overshoot in % of the change), each measured from where its own output was
    at the step (the run's: ``start``) toward ``target`` (absolute, the output's
    ``unit``). Null: fewer than two samples measured."""

    output: str
    unit: str
    t: float
    span: float
    start: float
    target: float
    run: StepInfoOut | None
    prediction: StepInfoOut | None


class RunPrediction(Model):
    """What the model predicts for a run (the same plant model, law, reference, excitation,
    start state and actuator limit with ideal sensors, its live changes replayed) and how
    far the recording is from it. ``n``: samples predicted (the run's, or the first
    ``ELAB_PREDICTION_SAMPLES``); ``compared``: recorded samples compared so far (a live
    run's grow); ``diverged_at``: s where the predicted loop diverged or the predicted
    controller failed (the prediction ends there); ``steps``: each step of the reference
    over the samples compared, the run's response beside the prediction's."""

    run_id: str
    model: str
    Ts: float
    n: int
    compared: int
    replayed: int
    diverged_at: float | None
    channels: list[PredictedChannel]
    gaps: list[PredictionGap]
    steps: list[PredictionStep]
    notes: list[str]
