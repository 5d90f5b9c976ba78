"""Designs on a kept model (LQR, placement, a gain, PID), any law's loop on a plant
(poles, margins, root locus) and a law as a file."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, RootModel

from elab.api.schemas.base import Complex, Finite, Model, Num
from elab.api.schemas.laws import Controller
from elab.api.schemas.models import MAX_MODEL_STATES, ModelMatrix, ModelNumber
from elab.api.schemas.plants import StepOut


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
    robust: bool = Field(
        True,
        description="with an output weight (given or Bryson's): lower it by factors of √2 "
        "until the loop on the model has at least 6 dB of gain and 30° of phase margin, "
        "so that a model's small errors (an identified resonance) do not undo the design",
    )


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
    output_weight: float | None = Field(
        None, description="LQR by an output weight: the q used (after robust lowering)"
    )
    weight_note: str | None = Field(
        None, description="how q was chosen, when the robust rule lowered it or could not"
    )
    on_plant: StepOut | None = Field(
        None,
        description="the same controller on the lab's physics model, as a run of it goes "
        "(noise-free sensors, the plant's actuator limit), its outputs absolute: what the "
        "identified model's step is checked against (null: it cannot run on the plant)",
    )


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
