"""The one stepping loop, compiled with Numba (cached on disk), and its parts.

It advances runs held in stacked, zero-padded arrays (leading axis = slot), so
one call steps any number of runs of any plant. Padding only adds exact zeros,
so a run gives the same bits alone or in a batch. Per sample :math:`k`:

.. math::
    y_k &= Q(C x_k + v_k) \\\\
    u_k &= \\mathrm{sat}(C_c \\xi_k + D_c w_k + e_k), \\quad w_k = [r_k, z_k] \\\\
    \\xi_{k+1} &= A_c \\xi_k + B_c w_k + L_w (u_k - C_c \\xi_k - D_c w_k - e_k) \\\\
    x_{k+1} &= A_d x_k + B_d u_k

with :math:`v` sensor noise, :math:`Q` quantisation, :math:`z = x` (state
feedback) or :math:`y`, :math:`e` the excitation added at the plant input.
Row ``i`` of ``out`` is ``[r, u, y (NY), x (NX)]`` at sample ``k`` (state before
the update), with the operating point ``y_op``, ``x_op`` added: absolute values.

Its three parts are compiled functions of their own, each callable alone on the
run in slot ``s`` of such arrays (a single run: slot 0 of arrays of one):
:func:`measure` (the sensors), :func:`control_step` (the controller: what the
rig's host loop runs on real measurements) and :func:`plant_step` (the plant:
what a code controller is stepped against). The two steps write the next state
into scratch space and the caller commits it (``xc[s] = xcn``, ``x[s] = xn``):
written through inside the step, the commit kept LLVM from optimising the loop
(60 % slower). :func:`advance` composes them; the arithmetic, and so every bit,
is the same as when it was one function.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, inline="always")
def measure(s: int, C: Any, x: Any, v: Any, quantum: Any, y: Any) -> None:  # pragma: no cover
    """``y = Q(C x + v)``: the outputs (deviations) from the state ``x[s]``, sensor noise
    ``v`` and each output's quantum ``quantum[s]`` (0: none). ``C`` is (R, NY, NX);
    writes ``y`` (NY)."""
    for o in range(y.shape[0]):
        acc = 0.0
        for c in range(x.shape[1]):
            acc += C[s, o, c] * x[s, c]
        acc += v[o]
        q = quantum[s, o]
        if q > 0.0:
            acc = np.round(acc / q) * q
        y[o] = acc


@njit(cache=True, nogil=True, inline="always")
def control_step(
    s: int,
    r: float,
    z: Any,
    e: float,
    Ac: Any,
    Bc: Any,
    Cc: Any,
    Dc: Any,
    Lw: Any,
    u_lim: Any,
    xc: Any,
    xcn: Any,
) -> float:  # pragma: no cover
    """One sample of the discrete controller in slot ``s``: returns
    ``u = sat(Cc ξ + Dc [r, z] + e)`` (V) and writes the next controller state
    ``Ac ξ + Bc [r, z] + Lw (u − unsaturated u)`` (back-calculation anti-windup) into
    ``xcn`` (NC). ``z``: what it feeds back (outputs, or the states for true-state
    feedback; NZ = ``Dc.shape[1] − 1``)."""
    NZ, NC = Dc.shape[1] - 1, xc.shape[1]
    v = Dc[s, 0] * r
    for m in range(NZ):
        v += Dc[s, 1 + m] * z[m]
    for c in range(NC):
        v += Cc[s, c] * xc[s, c]
    v += e
    u: float = min(max(v, -u_lim[s]), u_lim[s])
    for a in range(NC):
        acc = Bc[s, a, 0] * r
        for m in range(NZ):
            acc += Bc[s, a, 1 + m] * z[m]
        for c in range(NC):
            acc += Ac[s, a, c] * xc[s, c]
        xcn[a] = acc + Lw[s, a] * (u - v)
    return u


@njit(cache=True, nogil=True, inline="always")
def plant_step(s: int, Ad: Any, Bd: Any, x: Any, u: float, xn: Any) -> None:  # pragma: no cover
    """The plant in slot ``s`` over one sample: writes ``Ad x + Bd u`` (the next state,
    deviations from the operating point) into ``xn`` (NX)."""
    for a in range(x.shape[1]):
        acc = Bd[s, a] * u
        for c in range(x.shape[1]):
            acc += Ad[s, a, c] * x[s, c]
        xn[a] = acc


@njit(cache=True, nogil=True)
def sense(
    C: Any, x: Any, v: Any, quantum: Any, y_op: Any, x_op: Any, y: Any, row: Any
) -> None:  # pragma: no cover - compiled; covered through elab.engines.coded
    """The sensors of the single run in slot 0 for a controller stepped outside the loop:
    writes ``y`` (absolute outputs: what the controller is given) and the ``y`` and ``x``
    columns of its row ``row[2:]`` (absolute, as :func:`advance` writes them)."""
    NX, NY = x.shape[1], y.shape[0]
    measure(0, C, x, v, quantum, y)
    for o in range(NY):
        row[2 + o] = y[o] + y_op[0, o]
    for c in range(NX):
        row[2 + NY + c] = x[0, c] + x_op[0, c]


@njit(cache=True, nogil=True)
def actuate(
    Ad: Any, Bd: Any, x: Any, u: float, xn: Any
) -> None:  # pragma: no cover - compiled; covered through elab.engines.coded
    """The plant of the single run in slot 0 over one sample with input ``u``, committed."""
    plant_step(0, Ad, Bd, x, u, xn)
    for c in range(x.shape[1]):
        x[0, c] = xn[c]


@njit(cache=True, nogil=True)
def advance(
    slots: Any,
    n: int,
    Ad: Any,
    Bd: Any,
    C: Any,
    Ac: Any,
    Bc: Any,
    Cc: Any,
    Dc: Any,
    Lw: Any,
    use_state: Any,
    u_lim: Any,
    quantum: Any,
    x: Any,
    xc: Any,
    exo: Any,
    exo_off: Any,
    y_op: Any,
    x_op: Any,
    out: Any,
) -> None:  # pragma: no cover - compiled; covered through elab.sim.batch
    NX, NY, NC = x.shape[1], C.shape[1], xc.shape[1]
    NZ = Dc.shape[1] - 1
    y, z = np.zeros(NY), np.zeros(NZ)
    xn, xcn = np.zeros(NX), np.zeros(NC)
    for s in slots:
        z[:] = 0.0
        off = exo_off[s]
        for i in range(n):
            j = off + i
            r = exo[s, j, 0]
            measure(s, C, x, exo[s, j, 2:], quantum, y)
            if use_state[s]:
                for c in range(NX):
                    z[c] = x[s, c]
            else:
                for o in range(NY):
                    z[o] = y[o]
            u = control_step(s, r, z, exo[s, j, 1], Ac, Bc, Cc, Dc, Lw, u_lim, xc, xcn)
            plant_step(s, Ad, Bd, x, u, xn)
            out[s, i, 0] = r
            out[s, i, 1] = u
            for o in range(NY):
                out[s, i, 2 + o] = y[o] + y_op[s, o]
            for c in range(NX):
                out[s, i, 2 + NY + c] = x[s, c] + x_op[s, c]
                x[s, c] = xn[c]
            for c in range(NC):
                xc[s, c] = xcn[c]
        exo_off[s] = off + n
