"""Continuous closed loops of a plant with a control law, and the loop transfer for margins.

Every law of :mod:`elab.laws` is first written as one LTI controller acting on
the reference :math:`r` and a measurement :math:`m` (the state :math:`x` for
true-state feedback, else the outputs :math:`y = Cx + Du`):

.. math::
    \\dot x_K = A_K x_K + B_r r + B_m m, \\qquad u = C_K x_K + D_r r + D_m m

Closing it around :math:`\\dot x = Ax + Bu` gives the loop from :math:`r` to
:math:`[y;\\, u]`; breaking it at the plant input gives :math:`L(s)`.
"""

from __future__ import annotations

import control as ct
import numpy as np

from elab.design import _polynomials
from elab.design._checks import Matrix
from elab.design.realise import Realisation, realise
from elab.errors import InvalidInput
from elab.laws import ControlLaw, has_feedback
from elab.plants import Plant


def closed_loop(plant: Plant, law: ControlLaw) -> ct.StateSpace:
    """The continuous closed loop from the scalar reference r to :math:`[y_0, …, y_{p-1}, u]`.

    With the controller in the form of the module docstring and the plant
    measurement :math:`m = C_m x + D_m' u`, the input solves
    :math:`u = (1 - D_m D_m')^{-1}(D_m C_m x + C_K x_K + D_r r)`; the states are
    :math:`[x;\\, x_K]`. For each law:

    - ``StateFeedback`` true state: :math:`u = K(e_i r - x)`, so
      :math:`A_{cl} = A - BK,\\ B_{cl} = B K e_i` (``i = plant.reference_state``);
    - ``StateFeedback`` velocity filters: :math:`\\hat x` takes position states
      from the outputs that equal them and velocities from
      :math:`\\omega_c s/(s + \\omega_c)` of an output (seed eq. 4.3–4.4);
    - ``PID`` and ``LTIController``: :math:`u = C(s)(r - y_{ref})`;
    - ``OpenLoop``: :math:`u = r`.

    Returns
    -------
    control.StateSpace
        Input ``"r"``, outputs the plant's outputs then its input, continuous.

    References
    ----------
    K. J. Åström and R. M. Murray, *Feedback Systems*, 2nd ed., 2021, §7.2 and §12.1.
    """
    K = realise(plant, law)
    M, N, C_m, D_mu = _open_loop(plant, K)
    F_u, g_u = _input_law(K, C_m, D_mu)
    n_K = K.A.shape[0]
    A = M + N @ F_u
    B = N @ g_u + np.vstack([np.zeros((plant.nx, 1)), K.B_r])
    C_y = np.hstack([plant.C, np.zeros((plant.ny, n_K))]) + plant.D @ F_u
    return ct.ss(
        A,
        B,
        np.vstack([C_y, F_u]),
        np.vstack([plant.D @ g_u, g_u]),
        inputs=["r"],
        outputs=[o.name for o in plant.outputs] + [plant.inputs[0].name],
        states=[s.name for s in plant.states] + list(K.states),
        name=f"{plant.id} closed loop",
    )


def loop_transfer(plant: Plant, law: ControlLaw) -> ct.TransferFunction:
    """The loop transfer :math:`L(s)` broken at the plant input (negative feedback).

    .. math:: L(s) = -K_m(s)\\, P_m(s), \\qquad
              K_m = C_K (sI - A_K)^{-1} B_m + D_m, \\quad P_m = C_m (sI - A)^{-1} B + D_m'

    which is :math:`K (sI - A)^{-1} B` for true-state feedback and
    :math:`C(s) P_{ref}(s)` for PID and LTI controllers. Round-off coefficients
    (below 1e-9 of the largest) are set to zero; nothing is cancelled.

    References
    ----------
    K. J. Åström and R. M. Murray, *Feedback Systems*, 2nd ed., 2021, §10.3.
    """
    if not has_feedback(law):
        raise InvalidInput(
            "law",
            law,
            "a feedback law (StateFeedback, PID or LTIController); "
            "an open loop has no loop transfer",
        )
    K = realise(plant, law)
    M, N, C_m, D_mu = _open_loop(plant, K)
    L = ct.ss2tf(ct.ss(M, N, -np.hstack([K.D_m @ C_m, K.C]), -K.D_m @ D_mu))
    num = _polynomials.clean(np.asarray(L.num_array[0][0], dtype=np.float64), 1e-9)
    den = _polynomials.clean(np.asarray(L.den_array[0][0], dtype=np.float64), 1e-9)
    return ct.tf(num, den)


def _open_loop(plant: Plant, K: Realisation) -> tuple[Matrix, Matrix, Matrix, Matrix]:
    """States :math:`[x; x_K]` driven by u: :math:`\\dot z = M z + N u`, and the measurement."""
    if K.measures_state:
        C_m, D_mu = np.eye(plant.nx), np.zeros((plant.nx, 1))
    else:
        C_m, D_mu = np.asarray(plant.C), np.asarray(plant.D)
    M = np.block([[plant.A, np.zeros((plant.nx, K.A.shape[0]))], [K.B_m @ C_m, K.A]])
    N = np.vstack([plant.B, K.B_m @ D_mu])
    return M, N, C_m, D_mu


def _input_law(K: Realisation, C_m: Matrix, D_mu: Matrix) -> tuple[Matrix, Matrix]:
    """:math:`u = F_u [x; x_K] + g_u r` after solving the algebraic loop through D."""
    well_posed = 1.0 - float((K.D_m @ D_mu)[0, 0])
    if abs(well_posed) < 1e-12:
        raise InvalidInput(
            "controller",
            f"D_K D = {1.0 - well_posed:g}",
            "a well-posed loop: 1 − D_K D ≠ 0 (no algebraic loop of gain 1)",
        )
    F_u = np.hstack([K.D_m @ C_m, K.C]) / well_posed
    return F_u, K.D_r / well_posed
