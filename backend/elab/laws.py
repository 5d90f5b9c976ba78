"""Control laws as pure data.

These frozen dataclasses say *what* a controller is; :mod:`elab.sim.controllers`
turns one into the discrete state-space form the stepping loop runs, and
:mod:`elab.design` computes gains for them. The reference ``r`` is a scalar that
drives the plant's reference output (its ``reference_output``); for state
feedback it becomes the state reference ``x_ref = r e_i`` with ``i`` the
plant's ``reference_state``.

Sign convention (as python-control's ``lqr``): state feedback is
``u = K (x_ref − x)``, i.e. ``u = −K x`` for regulation, so the closed loop is
``A − B K``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, assert_never


@dataclass(frozen=True)
class StateFeedback:
    """State feedback :math:`u = K (x_{ref} - \\hat x)`, or with a reference gain
    :math:`u = N_r r - K \\hat x`.

    ``estimate="true_state"`` feeds back the simulated state itself (the
    textbook analysis); ``"velocity_filters"`` feeds back the measured outputs
    and the plant's band-limited differentiators (seed eq. 4.3–4.4), as the real
    rig must; ``"observer"`` a full-order Luenberger observer on the plant's model,
    :math:`\\dot{\\hat x} = A \\hat x + B u + L (y - C \\hat x - D u)`, with the gain ``L``
    (one row per state, one column per output) or placed at ``observer_poles``
    (python-control ``place`` on the dual system). ``Nr=None``: :math:`N_r = K_i`, the
    gain of the reference state (so that :math:`x_{ref} = r e_i`).
    """

    K: tuple[float, ...]
    estimate: Literal["true_state", "velocity_filters", "observer"] = "true_state"
    Nr: float | None = None
    L: tuple[tuple[float, ...], ...] | None = None
    observer_poles: tuple[complex, ...] | None = None


@dataclass(frozen=True)
class PID:
    """PID on the error :math:`e = r - y`, parallel form with a derivative filter and
    setpoint weights ``b`` (proportional) and ``c`` (derivative):

    .. math:: u = K_p (b r - y) + \\frac{K_i}{s} (r - y)
              + \\frac{K_d s}{T_f s + 1} (c r - y),
              \\qquad T_f = \\frac{K_d}{N K_p}

    (:math:`T_f = 0.01` s when :math:`K_p = 0`), discretised by Tustin.
    Anti-windup by back-calculation with tracking time ``Tt`` (default
    :math:`\\sqrt{T_i T_d}`, or :math:`T_i` without derivative action;
    Åström & Hägglund, *Advanced PID Control*, 2006, §3.5).
    """

    Kp: float
    Ki: float = 0.0
    Kd: float = 0.0
    N: float = 10.0
    Tt: float | None = None
    b: float = 1.0
    c: float = 1.0


@dataclass(frozen=True)
class LTIController:
    """Any SISO LTI controller acting on the error :math:`e = r - y`.

    Given as a transfer function ``num/den`` (descending powers) or as state
    space ``A, B, C, D``. ``dt=None`` means continuous (discretised by Tustin
    at the run's sample time); a number is the controller's own sample time,
    which must equal the run's. ``ff_num/ff_den``: a feed-forward transfer
    function from the reference to u, added (in the same time domain).

    ``B_r`` (n × 1) and ``D_r`` (1 × 1), with a state space only: the reference's own way
    into the controller, :math:`\\xi' = A \\xi + B e + B_r r,\\ u = C \\xi + D e + D_r r`
    (two degrees of freedom in one realisation, e.g. an observer whose estimate r does not
    excite; a separate feed-forward of the same dynamics would be unstable wherever the
    controller alone is).
    """

    num: tuple[float, ...] | None = None
    den: tuple[float, ...] | None = None
    A: tuple[tuple[float, ...], ...] | None = None
    B: tuple[tuple[float, ...], ...] | None = None
    C: tuple[tuple[float, ...], ...] | None = None
    D: tuple[tuple[float, ...], ...] | None = None
    dt: float | None = None
    ff_num: tuple[float, ...] | None = None
    ff_den: tuple[float, ...] | None = None
    B_r: tuple[tuple[float, ...], ...] | None = None
    D_r: tuple[tuple[float, ...], ...] | None = None


@dataclass(frozen=True)
class OpenLoop:
    """No feedback: the signal is the plant input, :math:`u = r`."""


@dataclass(frozen=True)
class CodeController:
    """A controller written in Python: ``source`` defines ``class Controller`` with
    ``reset(params)`` and ``step(t, y, r) -> u`` (docs/controllers.md). It runs in a
    sandboxed process (:mod:`elab.controllers.sandbox`), called once per sample with the
    measured outputs ``y`` in absolute units (as the rig gives them) and the reference
    ``r``; the plant's actuator limit applies to its ``u``. ``name``: the file's name."""

    source: str = field(repr=False)
    name: str = "controller.py"


ControlLaw = StateFeedback | PID | LTIController | OpenLoop | CodeController


def law_kind(law: ControlLaw) -> str:
    """The law's name in requests and controller files: ``state_feedback``, ``pid``,
    ``lti``, ``open_loop``; ``python`` for code."""
    match law:
        case StateFeedback():
            return "state_feedback"
        case PID():
            return "pid"
        case LTIController():
            return "lti"
        case OpenLoop():
            return "open_loop"
        case CodeController():
            return "python"
        case _:
            assert_never(law)


def is_code(law: ControlLaw) -> bool:
    """Whether the law is a student's Python code (stepped in a sandbox, sample by sample)."""
    match law:
        case CodeController():
            return True
        case StateFeedback() | PID() | LTIController() | OpenLoop():
            return False
        case _:
            assert_never(law)


def has_feedback(law: ControlLaw) -> bool:
    """Whether the loop is closed (every law but :class:`OpenLoop`)."""
    match law:
        case OpenLoop():
            return False
        case StateFeedback() | PID() | LTIController() | CodeController():
            return True
        case _:
            assert_never(law)


def own_sample_time(law: ControlLaw) -> float | None:
    """The sample time a discrete law was designed at (``None``: a continuous law, or one
    that runs at any sample time)."""
    match law:
        case LTIController(dt=dt):
            return dt
        case StateFeedback() | PID() | OpenLoop() | CodeController():
            return None
        case _:
            assert_never(law)
