"""Control laws as the discrete controller the stepping loop runs.

:func:`elab.design.realise` gives every law as one continuous controller from
:math:`w = [r, m]` to :math:`u` (:math:`m` the true state or the measured
outputs); here it is discretised by Tustin (python-control ``c2d``) and given
its anti-windup gain:

.. math::
    \\xi_{k+1} = A_c \\xi_k + B_c w_k + L_w (u_k - v_k), \\qquad
    v_k = C_c \\xi_k + D_c w_k

with :math:`v` the commanded and :math:`u` the applied (saturated) input.
Discrete LTI laws are taken as they are. The Tustin step is :func:`elab.lti.tustin`
(scipy's, as python-control's ``c2d`` calls it): python-control is imported only for a
law given as a transfer function or a discrete system.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, assert_never

import numpy as np
from numpy.typing import NDArray

from elab.design.realise import (
    feedforward_ss,
    lti_ss,
    pid_tracking_time,
    realise,
    reference_input,
)
from elab.errors import InvalidInput
from elab.laws import (
    PID,
    CodeController,
    ControlLaw,
    LTIController,
    OpenLoop,
    StateFeedback,
)
from elab.lti import tustin
from elab.plants.base import Plant
from elab.validate import finite_float

if TYPE_CHECKING:
    import control as ct

Array = NDArray[np.float64]


@dataclass(frozen=True)
class DiscreteController:
    """A controller ready to step: matrices of the form in the module docstring."""

    Ac: Array
    Bc: Array  # (nc, 1 + m)
    Cc: Array  # (nc,)
    Dc: Array  # (1 + m,)
    Lw: Array  # (nc,)
    feedback: Literal["state", "output"]

    @property
    def nc(self) -> int:
        return int(self.Ac.shape[0])


def controller_poles(law: ControlLaw, plant: Plant) -> NDArray[np.complex128]:
    """Poles of the continuous law (none for static gains, code and discrete laws)."""
    match law:
        case CodeController():
            return np.zeros(0, dtype=np.complex128)
        case LTIController() if law.dt is not None:
            return np.zeros(0, dtype=np.complex128)
        case StateFeedback() | PID() | LTIController() | OpenLoop():
            A = realise(plant, law, all_pid_states=True).A
            return np.asarray(np.linalg.eigvals(A) if A.size else np.zeros(0), np.complex128)
        case _:
            assert_never(law)


def discretise(law: ControlLaw, plant: Plant, Ts: float) -> DiscreteController:
    """Realise ``law`` for ``plant`` at sample time ``Ts`` (s). A code controller is
    stepped outside the loop (:mod:`elab.engines.coded`): its stand-in here gives u = 0."""
    match law:
        case CodeController():
            zeros = np.zeros(1 + plant.ny)
            none = np.zeros(0)
            return DiscreteController(
                np.zeros((0, 0)), np.zeros((0, zeros.size)), none, zeros, none, "output"
            )
        case LTIController() if law.dt is not None:
            return _discrete_lti(law, plant, Ts)
        case StateFeedback() | PID() | LTIController() | OpenLoop():
            return _tustin(law, plant, Ts)
        case _:
            assert_never(law)


def _tustin(
    law: StateFeedback | PID | LTIController | OpenLoop, plant: Plant, Ts: float
) -> DiscreteController:
    """A continuous law by Tustin, with its anti-windup gain."""
    real = realise(plant, law, all_pid_states=True)
    feedback: Literal["state", "output"] = "state" if real.measures_state else "output"
    n = real.A.shape[0]
    B, D = real.on_w()
    if n == 0:
        return DiscreteController(
            np.zeros((0, 0)), np.zeros((0, D.shape[1])), np.zeros(0), D[0], np.zeros(0), feedback
        )
    Ad, Bd, Cd, Dd = tustin(real.A, B, real.C, D, Ts)
    Lw = np.zeros(n)
    match law:
        case PID() if real.integrator is not None and law.Ki != 0:
            Lw[real.integrator] = Ts / (law.Ki * pid_tracking_time(law))
        case StateFeedback(estimate="observer"):
            # the observer learns the applied u, not the commanded one (to first order in Ts)
            Lw = Ts * (plant.B - real.B_m @ plant.D)[:, 0]
        case _:
            pass  # no integrator to unwind
    return DiscreteController(Ad, Bd, Cd.reshape(-1), Dd[0], Lw, feedback)


def _arrays(d: ct.StateSpace) -> tuple[Array, Array, Array, Array]:
    n = d.nstates
    return (
        np.asarray(d.A, np.float64).reshape(n, n),
        np.asarray(d.B, np.float64).reshape(n, -1),
        np.asarray(d.C, np.float64).reshape(-1)[:n],
        np.asarray(d.D, np.float64)[0],
    )


def _discrete_lti(law: LTIController, plant: Plant, Ts: float) -> DiscreteController:
    import control as ct  # here: only a discrete law needs python-control to step

    dt = finite_float("controller.dt", law.dt, 0.0, lo_open=True)
    if not math.isclose(dt, Ts, rel_tol=1e-9):
        raise InvalidInput("controller.dt", dt, f"the run's sample time {Ts:g} s")
    sys = lti_ss(law)
    e = np.zeros((1, 1 + plant.ny))  # the error e = r − y_ref from w = [r, y]
    e[0, 0], e[0, 1 + plant.reference_output] = 1.0, -1.0
    B, D = np.asarray(sys.B) @ e, np.asarray(sys.D) @ e
    own = reference_input(law)  # the reference's own input, beside the error's
    if own is not None:
        B[:, [0]] += own[0]
        D[:, [0]] += own[1]
    on_error = ct.ss(sys.A, B, sys.C, D, dt)
    ff = feedforward_ss(law)
    if ff is not None:  # in parallel, on r alone
        r = np.zeros((1, 1 + plant.ny))
        r[0, 0] = 1.0
        on_error = ct.parallel(
            on_error, ct.ss(ff.A, np.asarray(ff.B) @ r, ff.C, np.asarray(ff.D) @ r, dt)
        )
    return DiscreteController(*_arrays(on_error), np.zeros(on_error.nstates), "output")
