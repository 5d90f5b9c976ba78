"""Control laws on the wire: the ``Controller`` union (predefined, state feedback, PID,
any LTI, open loop)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from elab.api.schemas.base import Complex, Finite, Model


class PredefinedController(Model):
    """The plant's predefined controller."""

    kind: Literal["predefined"]


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
