"""Control laws realised as continuous LTI controllers: the one realisation.

Every law of :mod:`elab.laws` becomes a controller acting on the reference
:math:`r` and a measurement :math:`m` (the state :math:`x` for true-state
feedback, else the outputs :math:`y`):

.. math::
    \\dot\\xi = A \\xi + B_r r + B_m m, \\qquad u = C \\xi + D_r r + D_m m

:func:`elab.design.plant_loop` closes it around the plant for analysis;
:mod:`elab.sim.controllers` discretises it (Tustin) for the stepping loop.
PID has explicit states :math:`[\\int e,\\ e/(T_f s + 1)]` so the simulator
knows its integrator (anti-windup) and a live gain change keeps the state size.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, assert_never

import numpy as np

from elab.design import _polynomials
from elab.design._checks import Matrix, columns, rows, shaped, square
from elab.errors import DimensionError, InvalidInput
from elab.laws import PID, CodeController, ControlLaw, LTIController, OpenLoop, StateFeedback
from elab.plants import Plant
from elab.validate import finite_array, finite_float

# python-control is imported where a law needs it (a transfer function, an observer's
# poles, a system for analysis): a run of a state feedback or a PID is compiled without
# it (its imports bring matplotlib and scipy.signal: a second, docs/architecture.md)
if TYPE_CHECKING:
    import control as ct


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

    def on_w(self) -> tuple[Matrix, Matrix]:
        """B and D on the one input :math:`w = [r, m]`."""
        n, n_m = self.A.shape[0], self.D_m.shape[1]
        return np.hstack([self.B_r, self.B_m]).reshape(n, 1 + n_m), np.hstack([self.D_r, self.D_m])

    def ss(self) -> ct.StateSpace:
        """The controller as one system from :math:`[r, m]` to :math:`u`."""
        import control as ct

        B, D = self.on_w()
        return ct.ss(self.A, B, self.C.reshape(1, self.A.shape[0]), D)

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
    import control as ct

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
    match law:
        case StateFeedback():
            return _state_feedback(plant, law)
        case PID():
            return _pid(plant, law, all_pid_states)
        case LTIController():
            if law.dt is not None:
                raise InvalidInput(
                    "controller.dt",
                    law.dt,
                    "a continuous controller (dt=None); discrete laws are "
                    "taken as they are by elab.sim",
                )
            real = _with_reference(_error_feedback(plant, lti_ss(law)), reference_input(law))
            return _with_feedforward(real, feedforward_ss(law))
        case OpenLoop():
            return Realisation.static(np.ones((1, 1)), np.zeros((1, plant.ny)), False)
        case CodeController():
            raise InvalidInput(
                "controller",
                law.name,
                "a linear controller: a Python controller has no model to analyse; its "
                "report comes from a trial run in the sandbox",
            )
        case _:
            assert_never(law)


def _state_feedback(plant: Plant, law: StateFeedback) -> Realisation:
    K = _gain_row(plant, law.K)
    i = plant.reference_state
    if law.Nr is None and i is None:
        raise InvalidInput(
            "plant.reference_state", i, "a state index: state feedback tracks r via x_ref = r e_i"
        )
    if law.Nr is not None:
        Nr = np.array([[finite_float("controller.Nr", law.Nr)]])
    else:
        assert i is not None
        Nr = K[:, [i]]
    if law.estimate == "true_state":
        return Realisation.static(Nr, -K, True)
    if law.estimate == "observer":
        return _observer(plant, law, K, Nr)
    if law.estimate != "velocity_filters":
        raise InvalidInput(
            "controller.estimate", law.estimate, '"true_state", "velocity_filters" or "observer"'
        )
    P_y, P_z, A, B_m = _velocity_estimator(plant)
    names = tuple(f"{plant.states[f.state].name}_filter" for f in plant.velocity_filters)
    return Realisation(A, np.zeros((A.shape[0], 1)), B_m, -K @ P_z, Nr, -K @ P_y, False, names)


def observer_gain(plant: Plant, law: StateFeedback) -> Matrix:
    """The observer's ``L`` (nx × ny): given, or placed at ``law.observer_poles``."""
    given = law.L is not None
    if given == (law.observer_poles is not None):
        raise InvalidInput(
            "controller.L",
            law.L,
            "an observer needs either its gain L (one row per state, one column per "
            "output) or observer_poles (one per state)",
        )
    if law.L is not None:
        L = finite_array("controller.L", law.L)
        if L.shape != (plant.nx, plant.ny):
            raise DimensionError(
                "controller.L", law.L, f"{plant.nx} rows (states) × {plant.ny} columns (outputs)"
            )
        return L
    assert law.observer_poles is not None
    poles = np.asarray(law.observer_poles, dtype=np.complex128)
    if poles.shape != (plant.nx,) or not np.all(np.isfinite(poles)):
        raise DimensionError(
            "controller.observer_poles", law.observer_poles, f"{plant.nx} finite poles"
        )
    if np.any(poles.real >= 0):
        raise InvalidInput(
            "controller.observer_poles", law.observer_poles, "poles in the left half-plane"
        )
    import control as ct

    try:
        return np.asarray(ct.place(plant.A.T, plant.C.T, poles), dtype=np.float64).T
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise InvalidInput(
            "controller.observer_poles",
            law.observer_poles,
            f"poles the observer can be placed at (complex ones in conjugate pairs, each "
            f"at most rank(C) times): {exc}",
        ) from None


def _observer(plant: Plant, law: StateFeedback, K: Matrix, Nr: Matrix) -> Realisation:
    """:math:`\\dot{\\hat x} = (A - BK - LC + LDK) \\hat x + (B - LD) N_r r + L y`,
    :math:`u = N_r r - K \\hat x`."""
    L = observer_gain(plant, law)
    A, B, C, D = plant.A, plant.B, plant.C, plant.D
    A_o = A - B @ K - L @ C + L @ D @ K
    names = tuple(f"{st.name}_estimate" for st in plant.states)
    return Realisation(A_o, (B - L @ D) @ Nr, L, -K, Nr, np.zeros((1, plant.ny)), False, names)


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


def _with_feedforward(real: Realisation, ff: ct.StateSpace | None) -> Realisation:
    """``real`` with a feed-forward system from r to u in parallel (its states after)."""
    if ff is None:
        return real
    a, b, c, d = (np.asarray(m, dtype=np.float64) for m in (ff.A, ff.B, ff.C, ff.D))
    n, k = real.A.shape[0], a.shape[0]
    A = np.zeros((n + k, n + k))
    A[:n, :n], A[n:, n:] = real.A, a
    return Realisation(
        A,
        np.vstack([real.B_r, b]),
        np.vstack([real.B_m, np.zeros((k, real.B_m.shape[1]))]),
        np.hstack([real.C, c]),
        real.D_r + d,
        real.D_m,
        real.measures_state,
        real.states + tuple(f"feedforward[{j}]" for j in range(k)),
        real.integrator,
    )


def reference_input(law: LTIController) -> tuple[Matrix, Matrix] | None:
    """The law's own reference input ``(B_r, D_r)``, checked against its ``A`` (either
    alone: the other is zero); ``None`` without one."""
    if law.B_r is None and law.D_r is None:
        return None
    if law.A is None:
        raise InvalidInput(
            "controller.B_r",
            law.B_r,
            "a state-space controller (A, B, C, D) to go with B_r and D_r",
        )
    n = square("controller.A", law.A).shape[0]
    B_r = np.zeros((n, 1)) if law.B_r is None else shaped("controller.B_r", law.B_r, (n, 1))
    D_r = np.zeros((1, 1)) if law.D_r is None else shaped("controller.D_r", law.D_r, (1, 1))
    return B_r, D_r


def _with_reference(real: Realisation, given: tuple[Matrix, Matrix] | None) -> Realisation:
    """``real`` with the law's direct reference input added to its own."""
    if given is None:
        return real
    return dataclasses.replace(real, B_r=real.B_r + given[0], D_r=real.D_r + given[1])


def feedforward_ss(law: LTIController) -> ct.StateSpace | None:
    """The law's feed-forward transfer function from r to u (``ff_num/ff_den``), in the
    law's time domain; ``None`` without one."""
    if law.ff_num is None and law.ff_den is None:
        return None
    if law.ff_num is None or law.ff_den is None:
        raise InvalidInput("controller.ff_den", law.ff_den, "both ff_num and ff_den, or neither")
    return _proper("ff_num", law.ff_num, "ff_den", law.ff_den, _dt(law))


def lti_ss(law: LTIController) -> ct.StateSpace:
    """The LTI law as python-control state space (continuous, or discrete with ``law.dt``)."""
    import control as ct

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
    return _proper("num", law.num, "den", law.den, _dt(law))


def _proper(
    num_name: str, num_given: object, den_name: str, den_given: object, dt: float
) -> ct.StateSpace:
    """The transfer function ``num/den`` in state space, if it is proper."""
    import control as ct

    num = _polynomials.clean(finite_array(f"controller.{num_name}", num_given, (None,)), 0.0)
    den = _polynomials.clean(finite_array(f"controller.{den_name}", den_given, (None,)), 0.0)
    if den[0] == 0.0 or num.size > den.size:
        raise InvalidInput(
            f"controller.{num_name}",
            num_given,
            f"a proper transfer function: nonzero {den_name}, degree of {num_name} ≤ "
            f"degree of {den_name}",
        )
    return ct.tf2ss(ct.tf(num, den, dt))


def _dt(law: LTIController) -> float:
    if law.dt is None:
        return 0.0
    return finite_float("controller.dt", law.dt, 0.0, lo_open=True)


def _pid(plant: Plant, law: PID, all_states: bool) -> Realisation:
    """States :math:`[\\xi_i, \\xi_d]` with :math:`\\dot\\xi_i = r - y_{ref}`,
    :math:`T_f \\dot\\xi_d = (c r - y_{ref}) - \\xi_d`, and setpoint weights ``b``, ``c``:

    .. math:: u = K_p (b r - y_{ref}) + K_i \\xi_i + (K_d/T_f)\\,(c r - y_{ref} - \\xi_d)
    """
    Kp, Ki, Kd, Tf = _pid_parameters(law)
    b = finite_float("controller.b", law.b)
    c = finite_float("controller.c", law.c)
    keep = [all_states or Ki != 0.0, all_states or Kd != 0.0]
    A = np.diag([0.0, -1.0 / Tf])[np.ix_(keep, keep)]
    on_y = np.array([[1.0], [1.0 / Tf]])[keep]
    on_r = np.array([[1.0], [c / Tf]])[keep]
    out = np.array([[Ki, -Kd / Tf]])[:, keep]
    e_ref = np.eye(plant.ny)[[plant.reference_output]]
    names = ("pid_integral", "pid_derivative_filter")
    return Realisation(
        A,
        on_r,
        -on_y @ e_ref,
        out,
        np.array([[Kp * b + Kd / Tf * c]]),
        -(Kp + Kd / Tf) * e_ref,
        False,
        tuple(n for n, k in zip(names, keep, strict=True) if k),
        0 if keep[0] else None,
    )
