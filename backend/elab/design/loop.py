"""A model closed by a controller ``[r, y] → u`` (:mod:`elab.design.observed`), in the
model's domain: the closed loop, its verdict, step response, root locus and margins, and
the peak input a reference step asks for.

With the plant :math:`x' = Ax + Bu,\\ y = Cx + Du` and the controller
:math:`\\xi' = A_K \\xi + B_r r + B_y y,\\ u = C_K \\xi + D_r r + D_y y`, the input solves
:math:`(1 - D_y D) u = D_y C x + C_K \\xi + D_r r`; the closed loop has the states
:math:`[x;\\ \\xi]` and the outputs :math:`[y;\\ u]`. Breaking the loop at the plant input
gives :math:`L = -(D_y C,\\ C_K)` after :math:`(x, \\xi)` driven by u (negative feedback).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from warnings import catch_warnings, simplefilter

import control as ct
import numpy as np
from scipy.signal import BadCoefficients

from elab.design._checks import ComplexVector, readonly, sort_eigenvalues
from elab.design.analysis import stability
from elab.design.locus import RootLocus, root_locus
from elab.design.model import Model
from elab.design.response import (
    MIN_HORIZON,
    Margins,
    StepInfo,
    StepResponse,
    default_horizon,
    margins,
    step_info,
    step_response,
)
from elab.errors import InvalidInput
from elab.validate import finite_float

MAX_SAMPLES = 20_001  # of a discrete step response
MAX_POINTS = 2001  # of a step response as returned (the peak is taken on every sample)
_TOL = 1e-9


@dataclass(frozen=True)
class Loop:
    """The closed loop ``r → [y…, u]``, the loop transfer at the plant input, its poles
    (s or z) and the verdict ("asymptotically stable", "marginally stable", "unstable")."""

    closed: ct.StateSpace
    L: ct.StateSpace
    poles: ComplexVector
    verdict: str
    reason: str

    @property
    def stable(self) -> bool:
        return self.verdict == "asymptotically stable"


def close(m: Model, controller: ct.StateSpace) -> Loop:
    """The model closed by ``controller`` (module docstring)."""
    n, nk = m.nx, controller.nstates
    A_K, B_K, C_K, D_K = (
        np.asarray(x, dtype=np.float64)
        for x in (controller.A, controller.B, controller.C, controller.D)
    )
    A_K, C_K = A_K.reshape(nk, nk), C_K.reshape(1, nk)
    B_K = B_K.reshape(nk, D_K.shape[1])  # [r, y…]; a static controller has no rows
    B_r, B_y = B_K[:, [0]], B_K[:, 1:]
    D_r, D_y = D_K[:, [0]], D_K[:, 1:]
    well_posed = 1.0 - float((D_y @ m.D)[0, 0])
    if abs(well_posed) < 1e-12:
        raise InvalidInput("controller", "1 − D_K D = 0", "a loop without an algebraic loop")
    M = np.block([[m.A, np.zeros((n, nk))], [B_y @ m.C, A_K]])
    N = np.vstack([m.B, B_y @ m.D])
    F_u = np.hstack([D_y @ m.C, C_K]) / well_posed
    g_u = D_r / well_posed
    dt = 0 if m.Ts is None else m.Ts
    A = M + N @ F_u
    closed = ct.ss(
        A,
        N @ g_u + np.vstack([np.zeros((n, 1)), B_r]),
        np.vstack([np.hstack([m.C, np.zeros((m.ny, nk))]) + m.D @ F_u, F_u]),
        np.vstack([m.D @ g_u, g_u]),
        dt,
    )
    L = ct.ss(M, N, -np.hstack([D_y @ m.C, C_K]), -D_y @ m.D, dt)
    poles, said, reason = verdict(A, m.Ts)
    return Loop(closed, L, poles, said, reason)


def verdict(A: np.ndarray, Ts: float | None) -> tuple[ComplexVector, str, str]:
    if Ts is None:
        s = stability(A)
        return s.eigenvalues, s.verdict, s.reason
    z = readonly(sort_eigenvalues(np.linalg.eigvals(A)))
    outside = z[np.abs(z) > 1 + _TOL]
    if outside.size:
        return z, "unstable", f"{_text(outside[0])} outside the unit circle (|z| > 1)"
    on = z[np.abs(np.abs(z) - 1) <= _TOL]
    if not on.size:
        largest = float(np.max(np.abs(z), initial=0.0))
        return (
            z,
            "asymptotically stable",
            f"every pole inside the unit circle (|z| ≤ {largest:.4g})",
        )
    for p in np.unique(np.round(on, 9)):
        m = int(np.sum(np.abs(z - p) <= 1e-6))
        if A.shape[0] - np.linalg.matrix_rank(A - p * np.eye(A.shape[0]), tol=1e-6) < m:
            return z, "unstable", f"a repeated pole {_text(p)} on the unit circle"
    return z, "marginally stable", f"{_text(on[0])} on the unit circle"


def _text(p: complex) -> str:
    if abs(p.imag) < 1e-12:
        return f"pole {p.real:.4g}"
    return f"poles {p.real:.4g} ± {abs(p.imag):.4g}j"


def horizon(loop: Loop, Ts: float | None) -> float:
    """A step horizon (s): ten time constants of the slowest pole when stable (as
    :func:`~elab.design.response.default_horizon`); when not, until the fastest-growing
    mode has grown about e¹⁰ times (at most 10 s), so the curve stays finite."""
    p = loop.poles
    s = p if Ts is None else np.log(np.where(np.abs(p) > 1e-300, p, 1e-300)) / Ts
    growth = float(np.max(s.real, initial=-math.inf))
    T = default_horizon(s) if loop.stable or growth <= 1e-9 else min(10.0, 10.0 / growth)
    return T if Ts is None else max(T, 20 * Ts)


def step(loop: Loop, Ts: float | None, amplitude: float, T: float | None = None) -> StepResponse:
    """The loop's response to a step of r of height ``amplitude`` over ``T`` seconds
    (:func:`horizon` by default): outputs y and the input u, on every sample in discrete
    time (at most :data:`MAX_SAMPLES`), on 4001 points in continuous time."""
    amplitude = finite_float("amplitude", amplitude)
    shortest = MIN_HORIZON if Ts is None else max(MIN_HORIZON, 2 * Ts)  # two samples at least
    T = horizon(loop, Ts) if T is None else finite_float("T", T, shortest, 3600.0)
    if Ts is None:
        return step_response(loop.closed, T, 4001, amplitude, u_output=-1)
    n = min(MAX_SAMPLES, round(T / Ts) + 1)
    t = np.arange(n, dtype=np.float64) * Ts
    with np.errstate(all="ignore"):
        out = ct.forced_response(loop.closed, t, np.full(n, amplitude), squeeze=False)
    y = np.asarray(out.outputs, dtype=np.float64).reshape(loop.closed.noutputs, n)
    names = tuple(f"y[{i}]" for i in range(y.shape[0] - 1))
    return StepResponse(readonly(t), readonly(y[:-1].copy()), readonly(y[-1].copy()), names)


def loop_margins(loop: Loop, Ts: float | None) -> Margins:
    """Gain and phase margins of the loop broken at the plant input. Discrete loops on
    their frequency response (the polynomial method is ill-conditioned for poles near
    z = 1), as :func:`elab.controllers.report.check` does."""
    if Ts is None:
        return credible(margins(loop.L), loop.L)
    return frd_margins(loop.L)


def frd_margins(L: ct.StateSpace) -> Margins:
    """Margins of a discrete loop ``L`` on its frequency response (python-control's
    ``stability_margins(method="frd")``); ArithmeticError when that response is not finite
    (a gain of 1e308: its spline fit refused the points)."""
    with catch_warnings():
        simplefilter("ignore", BadCoefficients)
        simplefilter("ignore", RuntimeWarning)  # complex overflow warns despite errstate
        with np.errstate(all="ignore"):
            try:
                gm, pm, _, wpc, wgc, _ = ct.stability_margins(L, method="frd")
            except ValueError as exc:
                raise ArithmeticError(f"the loop's frequency response: {exc}") from None
    with np.errstate(divide="ignore"):
        gm_db = float(20.0 * np.log10(gm)) if np.isfinite(gm) else float(gm)
    return Margins(gm_db, float(pm), float(wgc), float(wpc))


def credible(m: Margins, L: ct.StateSpace) -> Margins:
    """``m`` without crossovers far beyond every pole and zero of L (more than 10³ times
    the largest), which are round-off of the polynomial method (a "300 dB" gain margin at
    6·10⁹ rad/s): there, the margin is infinite, as with no crossover."""
    A = np.asarray(L.A, dtype=np.float64)
    scale = 1e3 * max(1.0, float(np.max(np.abs(np.linalg.eigvals(A)), initial=0.0)))
    gm, wpc = (m.gain_margin_db, m.phase_crossover)
    pm, wgc = (m.phase_margin_deg, m.gain_crossover)
    if np.isfinite(wpc) and wpc > scale:
        gm, wpc = math.inf, math.nan
    if np.isfinite(wgc) and wgc > scale:
        pm, wgc = math.inf, math.nan
    return Margins(gm, pm, wgc, wpc)


@dataclass(frozen=True)
class Analysis:
    """What the design page shows of a loop: its step (and metrics when it settles), root
    locus, margins, and the peak |u| of the step of ``amplitude`` (None: unstable)."""

    loop: Loop
    step: StepResponse
    info: StepInfo | None
    locus: RootLocus
    margins: Margins
    peak_u: float | None
    amplitude: float


def analyse(
    m: Model, controller: ct.StateSpace, amplitude: float, T: float | None = None
) -> Analysis:
    """:func:`close`, :func:`step`, :func:`~elab.design.locus.root_locus` and
    :func:`loop_margins` of ``m`` with ``controller``."""
    loop = close(m, controller)
    r = step(loop, m.Ts, amplitude, T)
    finite = bool(np.all(np.isfinite(r.y)) and np.all(np.isfinite(r.u)))
    info = step_info(r.t, r.y[m.ref], amplitude) if loop.stable and finite else None
    peak = float(np.max(np.abs(r.u))) if loop.stable and finite else None
    return Analysis(loop, r, info, root_locus(loop.L), loop_margins(loop, m.Ts), peak, amplitude)


def thinned(r: StepResponse, limit: int = MAX_POINTS) -> StepResponse:
    """Every k-th sample of ``r`` so that at most ``limit`` remain (the last one kept)."""
    k = max(1, math.ceil((r.t.size - 1) / (limit - 1)))
    idx = np.unique(np.append(np.arange(0, r.t.size, k), r.t.size - 1))
    return StepResponse(
        readonly(r.t[idx].copy()),
        readonly(r.y[:, idx].copy()),
        readonly(r.u[idx].copy()),
        r.outputs,
    )
