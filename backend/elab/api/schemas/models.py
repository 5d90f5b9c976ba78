"""Identified models kept for design: the model to keep and the kept model."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from elab.api.schemas.base import Complex, Finite, Matrix, Model, Num
from elab.api.schemas.ident import TransferFunctionOut, VerdictOut

MAX_MODEL_STATES = 20  # elab.design.model.MAX_STATES
ModelNumber = Annotated[Finite, Field(ge=-1e12, le=1e12)]
ModelRow = Annotated[list[ModelNumber], Field(min_length=1, max_length=MAX_MODEL_STATES)]
ModelMatrix = Annotated[list[ModelRow], Field(min_length=1, max_length=MAX_MODEL_STATES)]


class ModelChannel(Model):
    name: str = Field(min_length=1, max_length=40)
    unit: str = Field("", max_length=20, description="SI: rad, m, V, …")


class VerdictIn(Model):
    """A verdict of identification's (:class:`VerdictOut`) as a model to keep carries it."""

    topic: str = Field(max_length=30)
    level: Literal["good", "caution", "poor"]
    finding: str = Field(max_length=1000)
    advice: str | None = Field(None, max_length=1000)


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
    verdicts: list[VerdictIn] = Field(
        [], max_length=20, description="identification's verdicts on it, shown beside its fit"
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
    verdicts: list[VerdictOut]
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
