"""The plant type: a continuous LTI model plus everything a lab needs to run it.

A plant is data. It owns no state and does no I/O; :mod:`elab.sim` steps it and
:mod:`elab.design` analyses it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources

import numpy as np
from numpy.typing import NDArray

from elab.laws import ControlLaw
from elab.lti import StateSpaceShape

Matrix = NDArray[np.float64]


@dataclass(frozen=True)
class Channel:
    """A named signal with its SI unit (``"rad"``, ``"rad/s"``, ``"V"``, ``"m"``)."""

    name: str
    unit: str
    label: str


@dataclass(frozen=True)
class VelocityFilter:
    """A band-limited differentiator :math:`\\omega_c s / (s + \\omega_c)`.

    It estimates state ``state`` from output ``output`` (seed eq. 4.3–4.4).
    """

    state: int
    output: int
    omega_c: float  # rad/s


@dataclass(frozen=True)
class Sensors:
    """Measurement imperfections per output: quantisation step and noise.

    ``quantum[i]`` is the resolution of output ``i`` in its unit (0 = ideal);
    ``noise_std[i]`` the standard deviation of additive white noise (applied
    only when a run asks for noise, with its seed).
    """

    quantum: tuple[float, ...]
    noise_std: tuple[float, ...]


@dataclass(frozen=True)
class SignalDefaults:
    """The defaults of the plant's analysis experiment: its reference, its duration and
    the absolute initial state it starts from (``x0=None``: the operating point), chosen
    so that every output visibly moves."""

    kind: str
    amplitude: float  # in the unit of the reference output
    period: float = 0.0  # s, for square and sine
    duration: float = 10.0  # s
    x0: tuple[float, ...] | None = None


@dataclass(frozen=True)
class LessonStep:
    """One run of a plant's lesson: the sequence a presenter steps through with one key
    (the chapter's: the plant alone, an arbitrary gain, the designed controller).
    ``signal`` holds its reference (the input in volts for an open loop), duration and
    start."""

    title: str
    text: str
    law: ControlLaw
    signal: SignalDefaults


@dataclass(frozen=True)
class IdentDefaults:
    """What the identification page proposes for a run of this plant: the models (the
    CLI's syntax), how many samples to keep one of (``decimate``) and why."""

    models: str = "arx:4,4,1; armax:2,2,2,1; n4sid"
    decimate: int = 1
    why: str = ""


@dataclass(frozen=True)
class Plant(StateSpaceShape):
    """A plant of the lab: continuous model :math:`\\dot x = A x + B u,\\; y = C x + D u`.

    States are deviations from ``operating_point`` (absolute state =
    ``operating_point + x``); results shown to users are absolute.
    """

    id: str
    name: str
    summary: str
    A: Matrix
    B: Matrix
    C: Matrix
    D: Matrix
    states: tuple[Channel, ...]
    inputs: tuple[Channel, ...]
    outputs: tuple[Channel, ...]
    u_max: float  # V, symmetric actuator limit
    saturate: bool  # whether runs saturate at u_max by default
    Ts: float  # s, default sample time
    reference_output: int
    reference_state: int | None
    predefined: ControlLaw
    predefined_design: str  # how the predefined controller was obtained
    sensors: Sensors
    signal: SignalDefaults
    operating_point: Matrix
    initial_state_ranges: tuple[tuple[int, float, float], ...] = ()  # (state, lo, hi) absolute
    velocity_filters: tuple[VelocityFilter, ...] = ()
    experiments: tuple[str, ...] = ("analysis", "identification", "design")
    modes: tuple[str, ...] = ("simulation",)
    notes: tuple[str, ...] = field(default=())
    identification: IdentDefaults = IdentDefaults()
    lesson: tuple[LessonStep, ...] = ()

    @property
    def rest(self) -> dict[str, float]:
        """Every recorded channel's value at the plant's rest: an output's at the
        operating point, the reference's (that of the output it is for), a state's (``x_``
        and its name), the input's 0 (every plant rests at u = 0)."""
        y_op = np.asarray(self.C, dtype=np.float64) @ np.asarray(self.operating_point)
        values = {c.name: float(y_op[i]) for i, c in enumerate(self.outputs)}
        states = zip(self.states, self.operating_point, strict=True)
        values |= {f"x_{c.name}": float(v) for c, v in states}
        values |= {c.name: 0.0 for c in self.inputs}
        values["r"] = float(y_op[self.reference_output])
        return values

    @property
    def output_ranges(self) -> tuple[tuple[int, float, float], ...]:
        """``(output, lo, hi)``: the absolute range of each output that measures a state
        with an ``initial_state_ranges`` entry (where the linear model holds)."""
        return tuple(
            (i, lo, hi)
            for s, lo, hi in self.initial_state_ranges
            for i in range(self.ny)
            if np.array_equal(self.C[i], np.eye(self.nx)[s])
        )

    @property
    def description(self) -> str:
        """The plant's description page (markdown with LaTeX equations)."""
        return (resources.files("elab.plants") / "descriptions" / f"{self.id}.md").read_text(
            encoding="utf-8"
        )


def frozen_matrix(rows: list[list[float]]) -> Matrix:
    """A read-only float64 2-D array, so a plant's model cannot be mutated."""
    m = np.array(rows, dtype=np.float64)
    m.setflags(write=False)
    return m
