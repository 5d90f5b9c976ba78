"""Control laws realised as continuous LTI controllers: the one realisation.

Every law of :mod:`elab.laws` becomes a controller acting on the reference
:math:`r` and a measurement :math:`m` (the state :math:`x` for true-state
feedback, else the outputs :math:`y`):

.. math::
    \\dot\\xi = A \\xi + B_r r + B_m m, \\qquad u = C \\xi + D_r r + D_m m

:func:`elab.design.closed_loop` closes it around the plant for analysis;
:mod:`elab.sim.controllers` discretises it (Tustin) for the stepping loop.
PID has explicit states :math:`[\\int e,\\ e/(T_f s + 1)]` so the simulator
knows its integrator (anti-windup) and a live gain change keeps the state size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np

from elab.design import _polynomials
from elab.design._checks import Matrix, columns, rows, shaped, square
from elab.errors import DimensionError, InvalidInput
from elab.laws import PID, CodeController, ControlLaw, LTIController, OpenLoop, StateFeedback
from elab.plants import Plant
from elab.validate import finite_array, finite_float


@dataclass(frozen=True)
class Realisation:
    """:math:`\\dot x_K = A x_K + B_r r + B_m m,\\ u = C x_K + D_r r + D_m m`."""

    A: Matrix
    B_r: Matrix
    B_m: Matrix
    C: Matrix
    D_r: Matrix
    D_m: Matrix
    measures_state: bool
    states: tuple[str, ...]
    integrator: int | None = None  # index of the PID's integral state, for anti-windup

    def ss(self) -> ct.StateSpace:
        """The controller as one system from :math:`[r, m]` to :math:`u`."""
        n, n_m = self.A.shape[0], self.D_m.shape[1]
        return ct.ss(
            self.A,
            np.hstack([self.B_r, self.B_m]).reshape(n, 1 + n_m),
            self.C.reshape(1, n),
            np.hstack([self.D_r, self.D_m]),
        )

    @classmethod
    def static(cls, D_r: Matrix, D_m: Matrix, measures_state: bool) -> Realisation:
        """A controller without states: :math:`u = D_r r + D_m m`."""
        n_m = D_m.shape[1]
        empty = np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((0, n_m)), np.zeros((1, 0))
        return cls(*empty, D_r, D_m, measures_state, ())


def pid_filter_time(law: PID) -> float:
    """:math:`T_f = K_d/(N K_p)`, or 0.01 s when :math:`K_d = 0` or :math:`K_p = 0`."""
    return _pid_parameters(law)[3]


def pid_tf(law: PID) -> ct.TransferFunction:
    """The PID controller of ``law`` as a transfer function.

    .. math:: C(s) = K_p + \\frac{K_i}{s} + \\frac{K_d s}{T_f s + 1},
              \\qquad T_f = \\frac{K_d}{N K_p}\\ (0.01\\ \\text{s if } K_p = 0)

    Terms with a zero gain are left out, so no pole–zero pair is created.

    References
    ----------
    K. J. Åström and T. Hägglund, *Advanced PID Control*, 2006, §3.2.
    """
    Kp, Ki, Kd, Tf = _pid_parameters(law)
    C = ct.tf([Kp], [1.0])
    if Ki != 0.0:
        C = C + ct.tf([Ki], [1.0, 0.0])
    if Kd != 0.0:
        C = C + ct.tf([Kd, 0.0], [Tf, 1.0])
    return C


def pid_tracking_time(law: PID) -> float:
    """Back-calculation tracking time :math:`T_t`: given, else :math:`\\sqrt{T_i T_d}`
    (:math:`T_i` without derivative action, 1 s without proportional action);
    Åström & Hägglund, *Advanced PID Control*, 2006, §3.5."""
    if law.Tt is not None:
        return finite_float("controller.Tt", law.Tt, 0.0, lo_open=True)
    if law.Kp > 0 and law.Ki > 0:
        Ti = law.Kp / law.Ki
        return math.sqrt(Ti * law.Kd / law.Kp) if law.Kd > 0 else Ti
    return 1.0


MIN_TF, MAX_TF = 1e-9, 1e9  # s: a derivative filter outside is a typo, not a design


def _pid_parameters(law: PID) -> tuple[float, float, float, float]:
    Kp = finite_float("controller.Kp", law.Kp)
    Ki = finite_float("controller.Ki", law.Ki)
    Kd = finite_float("controller.Kd", law.Kd)
    N = finite_float("controller.N", law.N, 0.0, lo_open=True)
    if Kp == 0.0 or Kd == 0.0:
        return Kp, Ki, Kd, 0.01  # T_f unused (no D) or undefined (no P): 0.01 s
    if Kd / Kp < 0.0:
        raise InvalidInput(
            "controller.Kd",
            Kd,
            f"the sign of Kp = {Kp:g}, so that the "
            "derivative filter time T_f = Kd / (N Kp) is positive",
        )
    Tf = abs(Kd) / (N * abs(Kp)) if N * abs(Kp) > 0.0 else math.inf
    if not MIN_TF <= Tf <= MAX_TF:
        raise InvalidInput(
            "controller.N",
            N,
            f"a filter N giving T_f = Kd / (N Kp) in "
            f"[{MIN_TF:g}, {MAX_TF:g}] s (here T_f = {Tf:.3g} s)",
        )
    return Kp, Ki, Kd, Tf


def realise(plant: Plant, law: ControlLaw, *, all_pid_states: bool = False) -> Realisation:
    """``law`` for ``plant`` as a continuous controller (module docstring).

    ``all_pid_states`` keeps both PID states even when a gain is zero (the
    simulator's choice, so live gain changes keep the state size); analysis
    leaves them out, so no pole of an unused state appears in the loop.
    """
    if plant.nu != 1:
        raise InvalidInput("plant", plant.id, "a single-input plant")
    if isinstance(law, StateFeedback):
        return _state_feedback(plant, law)
    if isinstance(law, PID):
        return _pid(plant, law, all_pid_states)
    if isinstance(law, LTIController):
        if law.dt is not None:
            raise InvalidInput(
                "controller.dt",
                law.dt,
                "a continuous controller (dt=None); discrete laws are "
                "taken as they are by elab.sim",
            )
        return _error_feedback(plant, lti_ss(law))
    if isinstance(law, OpenLoop):
        return Realisation.static(np.ones((1, 1)), np.zeros((1, plant.ny)), False)
    if isinstance(law, CodeController):
        raise InvalidInput(
            "controller",
            law.name,
            "a linear controller: a Python controller has no model to analyse; its report "
            "comes from a trial run in the sandbox",
        )
    raise InvalidInput("law", law, "StateFeedback, PID, LTIController or OpenLoop")


def _state_feedback(plant: Plant, law: StateFeedback) -> Realisation:
    K = _gain_row(plant, law.K)
    i = plant.reference_state
    if i is None:
        raise InvalidInput(
            "plant.reference_state", i, "a state index: state feedback tracks r via x_ref = r e_i"
        )
    if law.estimate == "true_state":
        return Realisation.static(K[:, [i]], -K, True)
    if law.estimate != "velocity_filters":
        raise InvalidInput(
            "controller.estimate", law.estimate, '"true_state" or "velocity_filters"'
        )
    P_y, P_z, A, B_m = _velocity_estimator(plant)
    names = tuple(f"{plant.states[f.state].name}_filter" for f in plant.velocity_filters)
    return Realisation(
        A, np.zeros((A.shape[0], 1)), B_m, -K @ P_z, K[:, [i]], -K @ P_y, False, names
    )


def _gain_row(plant: Plant, gains: tuple[float, ...]) -> Matrix:
    K = finite_array("controller.K", gains)
    if K.shape != (plant.nx,):
        states = ", ".join(s.name for s in plant.states)
        raise DimensionError("controller.K", gains, f"{plant.nx} gains, one per state ({states})")
    return K.reshape(1, plant.nx)


def _velocity_estimator(plant: Plant) -> tuple[Matrix, Matrix, Matrix, Matrix]:
    """:math:`\\hat x = P_y y + P_z z` with filter states :math:`\\dot z = A z + B_m y`.

    Filter k keeps :math:`z_k` = the low-passed output, so
    :math:`\\hat x_j = \\omega_c (y_o - z_k) = \\frac{\\omega_c s}{s + \\omega_c} y_o`.
    """
    filters = plant.velocity_filters
    P_y, P_z = np.zeros((plant.nx, plant.ny)), np.zeros((plant.nx, len(filters)))
    A, B_m = np.zeros((len(filters), len(filters))), np.zeros((len(filters), plant.ny))
    for k, f in enumerate(filters):
        A[k, k], B_m[k, f.output] = -f.omega_c, f.omega_c
        P_y[f.state, f.output], P_z[f.state, k] = f.omega_c, -f.omega_c
    for j in sorted(set(range(plant.nx)) - {f.state for f in filters}):
        P_y[j, _output_equal_to_state(plant, j)] = 1.0
    return P_y, P_z, A, B_m


def _output_equal_to_state(plant: Plant, j: int) -> int:
    unit = np.eye(plant.nx)[j]
    for o in range(plant.ny):
        if np.array_equal(plant.C[o], unit) and not np.any(plant.D[o]):
            return o
    raise InvalidInput(
        "controller.estimate",
        "velocity_filters",
        f"every state measured by an output or estimated by a velocity filter; "
        f"state {j} ({plant.states[j].name}) of {plant.id} has neither",
    )


def _error_feedback(plant: Plant, controller: ct.StateSpace) -> Realisation:
    """:math:`u = C(s)(r - y_{ref})` for a SISO controller in state space."""
    a, b, c, d = (
        np.asarray(m, dtype=np.float64)
        for m in (controller.A, controller.B, controller.C, controller.D)
    )
    e_ref = np.eye(plant.ny)[[plant.reference_output]]
    names = tuple(f"controller[{k}]" for k in range(a.shape[0]))
    return Realisation(a, b, -b @ e_ref, c, d, -d @ e_ref, False, names)


def lti_ss(law: LTIController) -> ct.StateSpace:
    """The LTI law as python-control state space (continuous, or discrete with ``law.dt``)."""
    given_tf = law.num is not None and law.den is not None
    given_ss = all(m is not None for m in (law.A, law.B, law.C, law.D))
    if given_tf == given_ss:
        raise InvalidInput("controller", law, "either num and den, or A, B, C and D")
    if given_ss:
        A = square("controller.A", law.A)
        C = rows("controller.C", law.C, A.shape[0])
        if C.shape[0] != 1:
            raise DimensionError("controller.C", law.C, "one row (a single output)")
        return ct.ss(
            A,
            columns("controller.B", law.B, A.shape[0]),
            C,
            shaped("controller.D", law.D, (1, 1)),
            _dt(law),
        )
    num = _polynomials.clean(finite_array("controller.num", law.num, (None,)), 0.0)
    den = _polynomials.clean(finite_array("controller.den", law.den, (None,)), 0.0)
    if den[0] == 0.0 or num.size > den.size:
        raise InvalidInput(
            "controller.num",
            law.num,
            "a proper transfer function: nonzero den, degree of num ≤ degree of den",
        )
    return ct.tf2ss(ct.tf(num, den, _dt(law)))


def _dt(law: LTIController) -> float:
    if law.dt is None:
        return 0.0
    return finite_float("controller.dt", law.dt, 0.0, lo_open=True)


def _pid(plant: Plant, law: PID, all_states: bool) -> Realisation:
    """States :math:`[\\xi_i, \\xi_d]` with :math:`\\dot\\xi_i = e`,
    :math:`T_f \\dot\\xi_d = e - \\xi_d`, :math:`e = r - y_{ref}`:

    .. math:: u = (K_p + K_d/T_f)\\, e + K_i \\xi_i - (K_d/T_f)\\, \\xi_d
    """
    Kp, Ki, Kd, Tf = _pid_parameters(law)
    keep = [all_states or Ki != 0.0, all_states or Kd != 0.0]
    A = np.diag([0.0, -1.0 / Tf])[np.ix_(keep, keep)]
    b = np.array([[1.0], [1.0 / Tf]])[keep]
    c = np.array([[Ki, -Kd / Tf]])[:, keep]
    e_ref = np.eye(plant.ny)[[plant.reference_output]]
    names = ("pid_integral", "pid_derivative_filter")
    return Realisation(
        A,
        b,
        -b @ e_ref,
        c,
        np.array([[Kp + Kd / Tf]]),
        -(Kp + Kd / Tf) * e_ref,
        False,
        tuple(n for n, k in zip(names, keep, strict=True) if k),
        0 if keep[0] else None,
    )
