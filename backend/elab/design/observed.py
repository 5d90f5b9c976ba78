"""Controllers for a :class:`~elab.design.model.Model`: state feedback on an observer's
estimate (gains by LQR, pole placement or by hand), or a PID; and the law that runs one.

Every controller is one LTI system, in the model's domain, from the reference r and every
output y to u (inputs ``[r, y_0, …]``). State feedback on a model acts on the estimate of
a full-order observer (in discrete time the one-step predictor):

.. math::
    \\hat x' = A \\hat x + B u + L (y - C \\hat x - D u), \\qquad u = N_r r - K \\hat x

that is :math:`A_o = A - BK - LC + LDK`, input matrices :math:`[(B - LD) N_r,\\ L]`,
output :math:`-K`, feed-through :math:`[N_r,\\ 0]`. Its estimation error is not excited
by r, so the response to r is state feedback's (the separation principle); the loop's
margins are those of observer and gain together, as the controller runs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np

from elab.design._checks import ComplexVector, Matrix, complex_vector, readonly
from elab.design.model import Model
from elab.design.realise import feedforward_ss, lti_ss, pid_tf, reference_input
from elab.design.synthesis import LQR, Placement, dlqr, lqr, place
from elab.errors import DimensionError, InvalidInput
from elab.laws import PID, LTIController
from elab.validate import finite_array, finite_float

OBSERVER_SPEED = 3.0  # default observer poles: state feedback's, this many times faster
_MIN_RATE = 0.1  # 1/s: the slowest decay of an unstable pole moved into the stable region
_MAX_RADIUS = 0.99  # and the largest |z| of one in discrete time (before speeding up)


def lqr_gain(m: Model, Q: Any, R: Any) -> LQR:
    """LQR on the model: :func:`~elab.design.synthesis.lqr` in continuous time,
    :func:`~elab.design.synthesis.dlqr` in discrete time (same weights, same K sign)."""
    return (lqr if m.Ts is None else dlqr)(m.A, m.B, Q, R)


def output_weight(m: Model, q: float) -> Matrix:
    """:math:`Q = q\\, C_r^T C_r`: a weight on the reference output alone (Bryson's rule:
    :math:`q = (u_{max}/y_{max})^2` with R = 1)."""
    q = finite_float("output_weight", q, 0.0, lo_open=True)
    c = m.C[[m.ref]]
    return q * (c.T @ c)


def place_gain(m: Model, poles: Any) -> Placement:
    """Pole placement on the model (poles in s, or in z for a discrete model)."""
    return place(m.A, m.B, poles)


def gain_row(m: Model, K: Any) -> Matrix:
    """A typed gain: one number per model state."""
    arr = finite_array("K", K)
    if arr.size != m.nx or arr.ndim > 2:
        raise DimensionError("K", f"{arr.size} gains", f"{m.nx} gains, one per model state")
    return arr.reshape(1, m.nx)


def default_observer_poles(sf_poles: Any, Ts: float | None) -> ComplexVector:
    """Observer poles from the state feedback's: each moved into the stable region if it
    is not (a slowest decay of 0.1/s; |z| ≤ 0.99), then made :data:`OBSERVER_SPEED` times
    faster: :math:`s \\to 3s`, which is :math:`z \\to z^3` (Franklin & Powell's rule of
    thumb: an estimate two to six times faster than the loop)."""
    p = np.asarray(sf_poles, dtype=np.complex128)
    if Ts is None:
        floor = np.maximum.reduce([np.abs(p.real), 0.1 * np.abs(p), np.full(p.size, _MIN_RATE)])
        re = np.where(p.real < 0, p.real, -floor)
        return np.asarray(OBSERVER_SPEED * (re + 1j * p.imag), dtype=np.complex128)
    r = np.abs(p)
    with np.errstate(divide="ignore"):
        radius = np.where(r < 1, r, np.minimum(1 / r, _MAX_RADIUS))
    return np.asarray((radius * np.exp(1j * np.angle(p))) ** OBSERVER_SPEED, np.complex128)


def observer_gain(m: Model, poles: Any) -> Matrix:
    """L (nx × ny) with :math:`\\operatorname{eig}(A - LC)` at ``poles``: pole placement on
    the dual pair :math:`(A^T, C^T)`."""
    try:
        return np.asarray(place(m.A.T, m.C.T, poles).K.T, dtype=np.float64)
    except InvalidInput as e:
        allowed = e.allowed.replace("controllable (A, B)", "observable (A, C)")
        raise InvalidInput("observer_poles", e.value, allowed) from None


def reference_gain(m: Model, K: Matrix) -> float:
    """:math:`N_r` giving the loop a unit steady-state gain from r to the reference output:
    :math:`N_r = 1 / G_{cl}(0)` (continuous) or :math:`1 / G_{cl}(1)` (discrete), with
    :math:`G_{cl}` the transfer of :math:`(A - BK,\\ B,\\ C_r - D_r K,\\ D_r)`."""
    n = m.nx
    at = np.zeros((n, n)) if m.Ts is None else np.eye(n)  # s = 0, or z = 1
    c, d = m.C[[m.ref]], m.D[[m.ref]]
    try:
        x = np.linalg.solve(at - (m.A - m.B @ K), m.B)
    except np.linalg.LinAlgError:
        x = None
    dc = None if x is None else float(((c - d @ K) @ x + d)[0, 0])
    if dc is None or not np.isfinite(dc) or abs(dc) < 1e-12:
        where = "s = 0" if m.Ts is None else "z = 1"
        raise InvalidInput(
            "K",
            np.ravel(K).tolist(),
            f"a gain whose loop passes a constant reference (here the loop has a pole or "
            f"a zero at {where}, so no reference gain Nr makes the output follow r)",
        )
    return 1.0 / dc


@dataclass(frozen=True)
class ObservedFeedback:
    """State feedback on an observer: the gains and the controller ``[r, y] → u``."""

    K: Matrix  # 1 × nx
    Nr: float
    L: Matrix  # nx × ny
    observer_poles: ComplexVector
    controller: ct.StateSpace


def observed_feedback(m: Model, K: Any, observer_poles: Any = None) -> ObservedFeedback:
    """The controller of the module docstring for gain ``K``; observer poles given, or
    :func:`default_observer_poles`. ``Nr`` from :func:`reference_gain`."""
    K = gain_row(m, K)
    if observer_poles is None:
        obs = default_observer_poles(np.linalg.eigvals(m.A - m.B @ K), m.Ts)
    else:
        obs = complex_vector("observer_poles", observer_poles)
        if obs.size != m.nx:
            raise DimensionError("observer_poles", obs.size, f"{m.nx} poles, one per state")
    L = observer_gain(m, obs)
    Nr = reference_gain(m, K)
    A_o = m.A - m.B @ K - L @ m.C + L @ m.D @ K
    B_o = np.hstack([(m.B - L @ m.D) * Nr, L])
    D_o = np.hstack([[[Nr]], np.zeros((1, m.ny))])
    controller = ct.ss(A_o, B_o, -K, D_o, 0 if m.Ts is None else m.Ts)
    return ObservedFeedback(readonly(K), Nr, readonly(L), readonly(obs), controller)


def pid_controller(m: Model, law: PID) -> ct.StateSpace:
    """The PID of ``law`` on the error :math:`e = r - y_{ref}` (setpoint weights 1), as the
    controller ``[r, y] → u``: continuous, or Tustin at Ts (what a run at Ts steps)."""
    if law.b != 1.0 or law.c != 1.0:
        raise InvalidInput("b, c", (law.b, law.c), "setpoint weights of 1 on a model")
    C = ct.ss(pid_tf(law))
    if m.Ts is not None:
        C = ct.c2d(C, m.Ts, method="tustin")
    on = np.zeros((1, 1 + m.ny))
    on[0, 0], on[0, 1 + m.ref] = 1.0, -1.0  # e = r − y_ref
    return ct.ss(C.A, np.asarray(C.B) @ on, C.C, np.asarray(C.D) @ on, C.dt)


def feedback_law(m: Model, controller: ct.StateSpace) -> LTIController:
    """A controller ``[r, y] → u`` of a one-output model as the lab's LTI law: with
    :math:`y = r - e`, :math:`\\xi' = A \\xi - B_y e + (B_r + B_y) r` and
    :math:`u = C \\xi - D_y e + (D_r + D_y) r`, one realisation whose states r and e share
    (its ``B_r``, ``D_r``), at the model's sample time (continuous: Tustin at the run's).
    What ``POST /runs`` takes and controller files hold."""
    if m.ny != 1:
        raise InvalidInput(
            "model",
            f"{m.ny} outputs",
            "one output: a run's LTI controller acts on the error of one output",
        )
    n = controller.nstates
    A, B, C, D = (
        np.asarray(x, dtype=np.float64).reshape(shape)
        for x, shape in (
            (controller.A, (n, n)),
            (controller.B, (n, 2)),
            (controller.C, (1, n)),
            (controller.D, (1, 2)),
        )
    )
    dt = None if m.Ts is None else m.Ts
    if n == 0:  # a static controller: one state that nothing drives keeps the form
        A, B, C = np.zeros((1, 1)), np.zeros((1, 2)), np.zeros((1, 1))
    return LTIController(
        A=_rows(A),
        B=_rows(-B[:, [1]]),
        C=_rows(C),
        D=_rows(-D[:, [1]]),
        dt=dt,
        B_r=_rows(B[:, [0]] + B[:, [1]]),
        D_r=_rows(D[:, [0]] + D[:, [1]]),
    )


def _rows(M: Matrix) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(x) for x in r) for r in M)


def two_dof(law: LTIController) -> ct.StateSpace:
    """An LTI law as the controller ``[r, y] → u`` a run steps (the inverse of
    :func:`feedback_law`): on the error e = r − y, with its own reference input ``B_r``,
    ``D_r`` and its feed-forward in parallel; in the law's own domain."""
    C = lti_ss(law)
    dt = C.dt
    B, D = np.asarray(C.B) @ [[1.0, -1.0]], np.asarray(C.D) @ [[1.0, -1.0]]
    own = reference_input(law)
    if own is not None:
        B[:, [0]] += own[0]
        D[:, [0]] += own[1]
    out = ct.ss(C.A, B, C.C, D, dt)
    ff = feedforward_ss(law)
    if ff is not None:
        on_r = np.asarray([[1.0, 0.0]])
        out = ct.parallel(
            out, ct.ss(ff.A, np.asarray(ff.B) @ on_r, ff.C, np.asarray(ff.D) @ on_r, dt)
        )
    return out
