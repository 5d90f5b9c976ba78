"""Rotary flexible link, nonlinear: the physics behind the seed's linear model (§4.1.1).

A servo of equivalent inertia :math:`J_{eq}` turns the base of a flexible link of
inertia :math:`J_l` (about the servo axis) and stiffness :math:`K_s`. States
:math:`x = [\\theta, \\alpha, \\dot\\theta, \\dot\\alpha]` (servo angle, link deflection
relative to the servo arm; rad, rad/s), input the voltage :math:`u` (V) asked of the
amplifier:

.. math::

    J_{eq}\\ddot\\theta = k_u\\,d(s(u)) - B_{eq}\\dot\\theta - \\tau_c
        \\tanh(\\dot\\theta/\\omega_s) + K_s\\alpha + B_l\\dot\\alpha

    J_l(\\ddot\\theta + \\ddot\\alpha) = -K_s\\alpha - B_l\\dot\\alpha

with :math:`s` the amplifier's saturation at :math:`\\pm u_{sat}` and :math:`d` the
motor's dead zone of half-width :math:`u_{dead}` (no torque below it, then linear
from its edge). :math:`B_{eq}` lumps the gearbox's viscous friction and the motor's
back-EMF, :math:`\\tau_c` is the Coulomb friction on the servo, smoothed over
:math:`\\omega_s` so that a fixed-step integrator stays stable, :math:`B_l` the link's
structural damping. Quanser, *Rotary Flexible Link, Laboratory Guide*, 2011, §2.

With :math:`\\tau_c = u_{dead} = B_l = 0` and :math:`|u| < u_{sat}` the model is linear
and equals the seed's A and B: the nominal parameters below are derived from them
with :math:`J_{eq} = 2.08\\cdot10^{-3}` kg m² (Quanser SRV02, high gear, with load),
which gives :math:`J_l = 3.3\\cdot10^{-3}` kg m², close to the 65 g, 0.381 m link's
:math:`mL^2/3 = 3.1\\cdot10^{-3}` kg m².
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput

Vector = NDArray[np.float64]

# the seed's A[2, 1], A[3, 1], A[2, 2] and B[2] (flexible_link.PLANT)
_A21, _A31, _A22, _B2 = 566.46, -921.77, -37.022, 65.113
_J_EQ = 2.08e-3  # kg m², SRV02 high gear with load (Quanser SRV02 User Manual)
_K_S = _A21 * _J_EQ


@dataclass(frozen=True)
class FlexibleLinkParameters:
    """Physical parameters of one rotary flexible link (SI units).

    ``J_eq`` servo-side inertia (kg m²); ``J_l`` link inertia about the servo axis
    (kg m²); ``K_s`` link stiffness (N m/rad); ``B_eq`` servo viscous damping with the
    back-EMF (N m s/rad); ``B_l`` link damping (N m s/rad); ``k_u`` motor torque per
    volt at the output shaft (N m/V); ``tau_c`` Coulomb friction on the servo (N m);
    ``omega_s`` the speed over which it changes sign (rad/s); ``u_dead`` the motor's
    dead zone (V); ``u_sat`` the amplifier's limit (V).
    """

    J_eq: float
    J_l: float
    K_s: float
    B_eq: float
    B_l: float
    k_u: float
    tau_c: float
    omega_s: float
    u_dead: float
    u_sat: float

    def __post_init__(self) -> None:
        for name in ("J_eq", "J_l", "K_s", "omega_s", "u_sat"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InvalidInput(f"parameters.{name}", value, "a finite number > 0")
        for name in ("B_eq", "B_l", "k_u", "tau_c", "u_dead"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InvalidInput(f"parameters.{name}", value, "a finite number >= 0")


NOMINAL = FlexibleLinkParameters(
    J_eq=_J_EQ,
    J_l=_K_S / -(_A31 + _A21),
    K_s=_K_S,
    B_eq=-_A22 * _J_EQ,
    B_l=0.0,
    k_u=_B2 * _J_EQ,
    tau_c=0.0,
    omega_s=0.02,
    u_dead=0.0,
    u_sat=10.0,
)
"""The seed's linear model exactly (no friction, no dead zone, no link damping)."""


def amplifier(u: float, p: FlexibleLinkParameters) -> float:
    """The voltage that makes torque (V): ``u`` clipped at ``±u_sat``, less the dead zone."""
    v = min(max(u, -p.u_sat), p.u_sat)
    if abs(v) <= p.u_dead:
        return 0.0
    return v - math.copysign(p.u_dead, v)


def f(t: float, x: Vector, u: float, p: FlexibleLinkParameters) -> Vector:
    """The state derivative :math:`\\dot x = f(t, x, u)` of the equations above.

    ``t`` (s) is unused (the plant is time-invariant) and kept for the integrators'
    signature; ``x`` as in the module docstring; ``u`` in V.
    """
    _, alpha, theta_dot, alpha_dot = (float(v) for v in x)
    theta_ddot, alpha_ddot = accelerations(alpha, theta_dot, alpha_dot, u, p)
    return np.array([theta_dot, alpha_dot, theta_ddot, alpha_ddot])


def accelerations(
    alpha: float, theta_dot: float, alpha_dot: float, u: float, p: FlexibleLinkParameters
) -> tuple[float, float]:
    """:math:`\\ddot\\theta` and :math:`\\ddot\\alpha` (rad/s²) of the equations above, on plain
    floats (what :func:`f` and :func:`rk4_floats` share)."""
    link = p.K_s * alpha + p.B_l * alpha_dot  # torque of the bent link on the servo
    friction = p.B_eq * theta_dot + p.tau_c * math.tanh(theta_dot / p.omega_s)
    theta_ddot = (p.k_u * amplifier(u, p) - friction + link) / p.J_eq
    return theta_ddot, -link / p.J_l - theta_ddot


State = tuple[float, float, float, float]


def rk4_floats(x: State, u: float, h: float, p: FlexibleLinkParameters) -> State:
    """:func:`rk4_step` on a tuple of floats: the same arithmetic, several times faster
    for a loop in Python (a trial of thousands of samples)."""
    th, al, thd, ald = x
    a1, b1 = accelerations(al, thd, ald, u, p)
    g = 0.5 * h
    a2, b2 = accelerations(al + g * ald, thd + g * a1, ald + g * b1, u, p)
    a3, b3 = accelerations(al + g * (ald + g * b1), thd + g * a2, ald + g * b2, u, p)
    a4, b4 = accelerations(al + h * (ald + g * b2), thd + h * a3, ald + h * b3, u, p)
    k = h / 6.0
    return (
        th + k * (thd + 2.0 * (thd + g * a1) + 2.0 * (thd + g * a2) + (thd + h * a3)),
        al + k * (ald + 2.0 * (ald + g * b1) + 2.0 * (ald + g * b2) + (ald + h * b3)),
        thd + k * (a1 + 2.0 * a2 + 2.0 * a3 + a4),
        ald + k * (b1 + 2.0 * b2 + 2.0 * b3 + b4),
    )


def rk4_step(x: Vector, u: float, h: float, p: FlexibleLinkParameters) -> Vector:
    """One classical Runge–Kutta step of length ``h`` (s) with ``u`` held (V)."""
    k1 = f(0.0, x, u, p)
    k2 = f(0.0, x + 0.5 * h * k1, u, p)
    k3 = f(0.0, x + 0.5 * h * k2, u, p)
    k4 = f(0.0, x + h * k3, u, p)
    return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
