"""The one stepping loop, compiled with Numba (cached on disk).

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
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def advance(
    slots: Any, n: int, Ad: Any, Bd: Any, C: Any, Ac: Any, Bc: Any, Cc: Any, Dc: Any,
    Lw: Any, use_state: Any, u_lim: Any, quantum: Any, x: Any, xc: Any, exo: Any,
    exo_off: Any, y_op: Any, x_op: Any, out: Any,
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
            for o in range(NY):
                acc = 0.0
                for c in range(NX):
                    acc += C[s, o, c] * x[s, c]
                acc += exo[s, j, 2 + o]
                q = quantum[s, o]
                if q > 0.0:
                    acc = np.round(acc / q) * q
                y[o] = acc
            if use_state[s]:
                for c in range(NX):
                    z[c] = x[s, c]
            else:
                for o in range(NY):
                    z[o] = y[o]
            v = Dc[s, 0] * r
            for m in range(NZ):
                v += Dc[s, 1 + m] * z[m]
            for c in range(NC):
                v += Cc[s, c] * xc[s, c]
            v += exo[s, j, 1]
            u = min(max(v, -u_lim[s]), u_lim[s])
            for a in range(NC):
                acc = Bc[s, a, 0] * r
                for m in range(NZ):
                    acc += Bc[s, a, 1 + m] * z[m]
                for c in range(NC):
                    acc += Ac[s, a, c] * xc[s, c]
                xcn[a] = acc + Lw[s, a] * (u - v)
            for a in range(NX):
                acc = Bd[s, a] * u
                for c in range(NX):
                    acc += Ad[s, a, c] * x[s, c]
                xn[a] = acc
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
