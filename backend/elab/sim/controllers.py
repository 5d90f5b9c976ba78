"""Control laws realised as the discrete controller the stepping loop runs.

Every law becomes one discrete state-space system from
:math:`w = [r, z_1, \\dots, z_m]` to :math:`u`:

.. math::
    \\xi_{k+1} = A_c \\xi_k + B_c w_k + L_w (u_k - v_k), \\qquad
    v_k = C_c \\xi_k + D_c w_k

where :math:`z` is the true state (``feedback="state"``) or the measured
outputs (``"output"``), :math:`v` the commanded and :math:`u` the applied
(saturated) input, and :math:`L_w` the anti-windup (back-calculation) gain.
Continuous laws are discretised by Tustin (python-control ``c2d``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import control as ct
import numpy as np
from numpy.typing import NDArray

from elab.errors import DimensionError, InvalidInput
from elab.laws import PID, ControlLaw, LTIController, OpenLoop, StateFeedback
from elab.plants.base import Plant
from elab.validate import finite_array, finite_float

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


@dataclass(frozen=True)
class _Continuous:
    """A law as continuous state space from w to u (before discretisation)."""

    sys: ct.StateSpace
    feedback: Literal["state", "output"]
    Lw_rate: Array  # anti-windup gain of the continuous state equation


def controller_poles(law: ControlLaw, plant: Plant) -> NDArray[np.complex128]:
    """Poles of the continuous law (empty for static gains and discrete laws)."""
    if isinstance(law, LTIController) and law.dt is not None:
        return np.zeros(0, dtype=np.complex128)
    cont = _continuous(law, plant)
    return np.linalg.eigvals(cont.sys.A) if cont.sys.nstates else np.zeros(0, np.complex128)


def discretise(law: ControlLaw, plant: Plant, Ts: float) -> DiscreteController:
    """Realise ``law`` for ``plant`` at sample time ``Ts`` (s)."""
    if isinstance(law, LTIController) and law.dt is not None:
        return _discrete_lti(law, plant, Ts)
    cont = _continuous(law, plant)
    sys = cont.sys
    if sys.nstates == 0:
        D = np.asarray(sys.D, dtype=np.float64)[0]
        return DiscreteController(np.zeros((0, 0)), np.zeros((0, D.size)), np.zeros(0), D,
                                  np.zeros(0), cont.feedback)
    d = ct.c2d(sys, Ts, method="tustin")
    return DiscreteController(np.asarray(d.A, dtype=np.float64), np.asarray(d.B, np.float64),
                              np.asarray(d.C, np.float64)[0], np.asarray(d.D, np.float64)[0],
                              cont.Lw_rate * Ts, cont.feedback)


def _continuous(law: ControlLaw, plant: Plant) -> _Continuous:
    if isinstance(law, StateFeedback):
        return _state_feedback(law, plant)
    if isinstance(law, PID):
        return _pid(law, plant)
    if isinstance(law, LTIController):
        return _lti(law, plant)
    if isinstance(law, OpenLoop):
        D = np.zeros((1, 1 + plant.ny))
        D[0, 0] = 1.0
        return _Continuous(_static(D), "output", np.zeros(0))
    raise InvalidInput("controller", law, "state feedback, PID, LTI or open loop")


def _static(D: Array) -> ct.StateSpace:
    m = D.shape[1]
    return ct.ss(np.zeros((0, 0)), np.zeros((0, m)), np.zeros((1, 0)), D)


def gain_vector(K: tuple[float, ...] | Array, plant: Plant) -> Array:
    """``K`` checked as a finite gain of length ``nx``."""
    return finite_array("controller.K", K, (plant.nx,))


def _state_feedback(law: StateFeedback, plant: Plant) -> _Continuous:
    K = gain_vector(law.K, plant)
    i = plant.reference_state
    if i is None:
        raise InvalidInput("controller", "state feedback", f"a PID or LTI law for {plant.id}")
    if law.estimate == "true_state":
        D = np.concatenate(([K[i]], -K))[None, :]
        return _Continuous(_static(D), "state", np.zeros(0))
    return _filtered_state_feedback(K, plant)


def _filtered_state_feedback(K: Array, plant: Plant) -> _Continuous:
    """u = K (x_ref − x̂), x̂ from outputs and band-limited differentiators.

    Filter :math:`\\omega s/(s+\\omega)` realised as :math:`\\dot\\xi = -\\omega\\xi + y_j`,
    :math:`\\hat x = \\omega y_j - \\omega^2 \\xi`.
    """
    filters = {vf.state: vf for vf in plant.velocity_filters}
    nf, m = len(filters), plant.ny
    A, B = np.zeros((nf, nf)), np.zeros((nf, 1 + m))
    C, D = np.zeros((1, nf)), np.zeros((1, 1 + m))
    D[0, 0] = K[plant.reference_state or 0]
    f = 0
    for s in range(plant.nx):
        if s in filters:
            vf = filters[s]
            A[f, f], B[f, 1 + vf.output] = -vf.omega_c, 1.0
            C[0, f] = K[s] * vf.omega_c**2
            D[0, 1 + vf.output] -= K[s] * vf.omega_c
            f += 1
        else:
            D[0, 1 + _output_of_state(plant, s)] -= K[s]
    return _Continuous(ct.ss(A, B, C, D), "output", np.zeros(nf))


def _output_of_state(plant: Plant, s: int) -> int:
    for j in range(plant.ny):
        row = plant.C[j]
        if row[s] == 1.0 and np.count_nonzero(row) == 1:
            return j
    raise InvalidInput("controller.estimate", "velocity_filters",
                       f"a plant whose state {plant.states[s].name} is measured or filtered")


def _error_input(plant: Plant) -> Array:
    """Row mapping w = [r, y] to the error e = r − y_ref."""
    E = np.zeros((1, 1 + plant.ny))
    E[0, 0], E[0, 1 + plant.reference_output] = 1.0, -1.0
    return E


def pid_filter_time(law: PID) -> float:
    """:math:`T_f = K_d / (N K_p)`, or 0.01 s when that is undefined."""
    if law.Kd > 0 and law.Kp > 0:
        return law.Kd / (law.N * law.Kp)
    return 0.01


def pid_tracking_time(law: PID) -> float:
    """Back-calculation tracking time :math:`T_t` (Åström & Hägglund 2006, §3.5)."""
    if law.Tt is not None:
        return finite_float("controller.Tt", law.Tt, 0.0, lo_open=True)
    if law.Kp > 0 and law.Ki > 0:
        Ti = law.Kp / law.Ki
        return math.sqrt(Ti * law.Kd / law.Kp) if law.Kd > 0 else Ti
    return 1.0


def _pid(law: PID, plant: Plant) -> _Continuous:
    """States [∫e, e/(T_f s+1)]: :math:`u = (K_p + K_d/T_f) e + K_i \\xi_i - (K_d/T_f)\\xi_d`."""
    for name in ("Kp", "Ki", "Kd"):
        finite_float(f"controller.{name}", getattr(law, name))
    finite_float("controller.N", law.N, 0.0, lo_open=True)
    Tf = pid_filter_time(law)
    E = _error_input(plant)
    A = np.array([[0.0, 0.0], [0.0, -1.0 / Tf]])
    B = np.vstack([E, E / Tf])
    C = np.array([[law.Ki, -law.Kd / Tf]])
    D = (law.Kp + law.Kd / Tf) * E
    Lw = np.zeros(2)
    if law.Ki != 0:
        Lw[0] = 1.0 / (law.Ki * pid_tracking_time(law))
    return _Continuous(ct.ss(A, B, C, D), "output", Lw)


def _lti_ss(law: LTIController) -> ct.StateSpace:
    if law.num is not None or law.den is not None:
        if law.num is None or law.den is None:
            raise InvalidInput("controller.num/den", (law.num, law.den), "both num and den")
        num = finite_array("controller.num", law.num, (None,))
        den = finite_array("controller.den", law.den, (None,))
        if den[0] == 0 or num.size > den.size:
            raise InvalidInput("controller.den", law.den,
                               "a proper transfer function: leading den ≠ 0, deg num ≤ deg den")
        return ct.ss(ct.tf(num, den, law.dt if law.dt is not None else 0))
    if law.A is None or law.B is None or law.C is None or law.D is None:
        raise InvalidInput("controller", law, "num and den, or all of A, B, C, D")
    A = finite_array("controller.A", law.A, (None, None))
    n = A.shape[0]
    B = finite_array("controller.B", law.B, (n, 1)) if n else np.zeros((0, 1))
    C = finite_array("controller.C", law.C, (1, n)) if n else np.zeros((1, 0))
    D = finite_array("controller.D", law.D, (1, 1))
    if A.shape != (n, n):
        raise DimensionError("controller.A", law.A, "a square matrix")
    return ct.ss(A, B, C, D, law.dt if law.dt is not None else 0)


def _on_error(sys: ct.StateSpace, plant: Plant) -> ct.StateSpace:
    E = _error_input(plant)
    return ct.ss(sys.A, np.asarray(sys.B) @ E, sys.C, np.asarray(sys.D) @ E, sys.dt)


def _lti(law: LTIController, plant: Plant) -> _Continuous:
    sys = _on_error(_lti_ss(law), plant)
    return _Continuous(sys, "output", np.zeros(sys.nstates))


def _discrete_lti(law: LTIController, plant: Plant, Ts: float) -> DiscreteController:
    dt = finite_float("controller.dt", law.dt, 0.0, lo_open=True)
    if not math.isclose(dt, Ts, rel_tol=1e-9):
        raise InvalidInput("controller.dt", dt, f"the run's sample time {Ts:g} s")
    d = _on_error(_lti_ss(law), plant)
    nc = d.nstates
    return DiscreteController(np.asarray(d.A, np.float64).reshape(nc, nc),
                              np.asarray(d.B, np.float64).reshape(nc, -1),
                              np.asarray(d.C, np.float64).reshape(-1)[:nc],
                              np.asarray(d.D, np.float64)[0], np.zeros(nc), "output")
