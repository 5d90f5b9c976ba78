"""The websocket stream's messages: the server's (``ServerMessage``), the client's
(``ClientMessage``) and the close codes."""

from __future__ import annotations

from enum import IntEnum
from typing import Annotated, Any, Literal

from pydantic import ConfigDict, Field

from elab.api.schemas.base import Model
from elab.api.schemas.runs import RunInfo, RunStateName, _Change


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


class EmergencyStop(Model):
    """The rig's emergency stop (the driver or an instructor), as ``POST /rig/estop``:
    0 V at the rig's next sample, whichever run this stream watches."""

    type: Literal["estop"]


class ResumeFrom(Model):
    """Send every sample from frame ``seq`` on, from the recording."""

    type: Literal["resume_from"]
    seq: int = Field(ge=0)


ClientMessage = Annotated[
    SetParams | Pause | Resume | Stop | EmergencyStop | ResumeFrom, Field(discriminator="type")
]
