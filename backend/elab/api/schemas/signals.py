"""Reference and excitation signals: the ``Signal`` union."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from elab.api.schemas.base import Finite, Model
from elab.sim.signals import PRBS_MIN_BAND


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
