"""Uploaded controllers: the upload, the report on it and a Python controller's compute
times."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from elab.api.schemas.base import Complex, Model
from elab.api.schemas.laws import Controller


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
