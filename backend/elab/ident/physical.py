"""A rotary flexible link's physical parameters from its recorded voltage, servo angle and
link deflection, in closed loop as the chapter runs its experiments (model kind ``link``).

The link's equations (:mod:`elab.plants.flexible_link_nonlinear`) divided by the
inertias, with the deflection as the strain gauge measures it, :math:`\\alpha_m = \\sigma
\\alpha` (:math:`\\sigma`: the gauge's true gain over its calibration):

.. math::

    \\ddot\\theta = g\\,(u - u_d \\operatorname{sgn} u) - c\\,\\dot\\theta
        - f \\operatorname{sgn}\\dot\\theta + (a/\\sigma)\\,\\alpha_m
        + (\\beta/\\sigma)\\,\\dot\\alpha_m \\qquad \\text{(servo)}

    \\ddot\\alpha_m = -\\sigma\\,\\ddot\\theta - b\\,\\alpha_m - \\beta_l\\,\\dot\\alpha_m
        \\qquad \\text{(link)}

with :math:`a = K_s/J_{eq}`, :math:`b = K_s/J_l`, :math:`c = B_{eq}/J_{eq}`,
:math:`g = k_u/J_{eq}`, :math:`f = \\tau_c/J_{eq}`, :math:`\\beta = B_l/J_{eq}`,
:math:`\\beta_l = B_l/J_l` and :math:`u_d` the motor's dead zone (V). Each equation is
linear in its parameters. The derivatives of the sampled signals come from the
state-variable filter :math:`\\lambda^3/(s+\\lambda)^3` (Young 1981; Garnier, Mensler and
Richard 2003, *Int. J. Control* 76(13)): every signal passes through
:math:`s^k\\lambda^3/(s+\\lambda)^3`, θ and α discretised as the continuous signals they are
(first-order hold), u and the sign terms as the piecewise-constant signals they are
(zero-order hold), so that the filtered equations hold for sampled data as for
continuous. Least squares on each equation gives its parameters and their standard
deviations; each equation has a constant besides (a gauge offset not tared away, a
constant torque). Only ratios are identifiable from u, θ and α: scaling every inertia and
torque by one factor changes no signal.

Coulomb friction acts as a sign only while the servo moves; where it sticks, friction is
whatever holds it. The voltage takes effect a little after its sample (the host's
answer arrives within the period): the servo equation is fitted for delays of 0, 1/8, …, 1
sample and the best fit kept. The servo equation is fitted only where the servo has turned
faster than ``moving`` (1 rad/s) for the whole of the last 0.15 s (the filters' memory;
the speed smoothed forwards and backwards, without delay); the link equation,
which friction does not enter, on every sample. The experiment therefore needs large
motions and a broadband input: the chapter's closed loop with a square reference of
tens of degrees and a PRBS added at the motor's input (docs/identification.md). Least
squares in closed loop is biased by sensor noise fed back through the controller; with
the rig's sensors (0.09° encoder steps, about 0.03° of gauge noise) and a 1 V PRBS the
bias stays inside the tolerances that tests/unit/ident/test_physical.py states over ten
rigs drawn across the hardware's spread.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData
from elab.ident.models import LinearModel
from elab.ident.parameters import LinkParameters

Array = NDArray[np.float64]
BANDWIDTH = 40.0  # rad/s, λ of the state-variable filter: above the link's 25–30 rad/s
MOVING = 1.0  # rad/s the servo must exceed, for STILL s, for a sample to enter its equation
STILL = 0.15  # s: the filter's memory, 6/λ
SPEED_FILTER = 60.0  # rad/s, the zero-phase low-pass that tells moving from sticking
SETTLE = 5.0  # filter time constants left out at the start (the filters' transient)
MIN_MOVING = 1000  # servo samples needed
MAX_TS = 0.01  # s: the filter needs λ far below the Nyquist frequency
DELAYS = np.linspace(0.0, 1.0, 9)  # of a sample, tried for the voltage's effect


def link(data: IdData) -> LinearModel:
    """The flexible link's physical parameters from ``data`` (input u in V, outputs θ then
    α in rad, not detrended), as a :class:`LinearModel` of its linear part whose
    ``parameters`` are :class:`LinkParameters`."""
    from scipy.ndimage import minimum_filter1d  # (scipy's imports: when a link is asked for)

    u, theta, alpha, Ts = _signals(data)
    F = _Filters(Ts)
    skip = int(SETTLE / BANDWIDTH / Ts) + 1
    th1, th2 = F.smooth(theta, 1), F.smooth(theta, 2)
    al0, al1, al2 = F.smooth(alpha, 0), F.smooth(alpha, 1), F.smooth(alpha, 2)
    speed = F.speed(theta)
    # moving now and through the filters' memory before (a trailing window): the filtered
    # equation at a sample sums the last few 1/λ s of its signals
    window = max(1, int(STILL / Ts))
    moving = minimum_filter1d(np.abs(speed), size=window, origin=(window - 1) // 2) > MOVING
    moving[:skip] = False
    if int(moving.sum()) < MIN_MOVING:
        raise InvalidInput(
            "data",
            f"{int(moving.sum())} samples with the servo turning faster than {MOVING:g} rad/s",
            f"at least {MIN_MOVING}: a link model needs large motions (the chapter's closed "
            "loop with a square reference of tens of degrees and a PRBS of about 1 V added "
            "at the input)",
        )
    # a constant in each equation: a gauge's offset not tared away, a torque that does
    # not change sign (both, filtered, a step of the constant)
    one = F.held(np.ones_like(u), 0)
    others = np.column_stack([th1, F.held(np.sign(speed), 0), al0, al1, one])
    volts, signs = F.held(u, 0), F.held(np.sign(u), 0)
    fits = []
    for d in DELAYS:  # the voltage takes effect d of a sample late: the best fit says d
        servo = np.column_stack([_late(volts, d), _late(signs, d), others])
        fits.append((_lstsq(servo[moving], th2[moving]), float(d)))
    (p1, s1, r1), delay = min(fits, key=lambda fit: fit[0][2])
    every = slice(skip, None)
    p2, s2, r2 = _lstsq(np.column_stack([th2, al0, al1, one])[every], al2[every])
    g, g_ud, minus_c, minus_f, a_s, beta_s, _ = p1
    sigma, b, beta_l = -p2[0], -p2[1], -p2[2]
    if not (g > 0 and sigma > 0):
        raise InvalidInput(
            "data",
            f"a motor gain of {g:.3g} and a gauge gain of {sigma:.3g}",
            "data in which the voltage turns the servo and bends the link (both gains "
            "positive): check the channels' order (u; θ, then α) and their signs",
        )
    est = {
        "a": a_s * sigma,
        "b": b,
        "c": -minus_c,
        "g": g,
        "f": -minus_f,
        "u_dead": g_ud / -g,
        "beta": beta_s * sigma,
        "beta_l": beta_l,
        "sigma": sigma,
    }
    std = {
        "a": abs(sigma) * s1[4],
        "b": s2[1],
        "c": s1[2],
        "g": s1[0],
        "f": s1[3],
        "u_dead": s1[1] / abs(g),
        "beta": abs(sigma) * s1[5],
        "beta_l": s2[2],
        "sigma": s2[0],
    }
    params = LinkParameters(
        **{k: float(v) for k, v in est.items()},
        std={k: float(v) for k, v in std.items()},
        samples=data.N,
        moving_samples=int(moving.sum()),
        bandwidth=BANDWIDTH,
        residual_rms=(r1, r2),
        input_delay=delay * data.Ts,
    )
    return _model(params, data)


class _Filters:
    """The state-variable filter's derivatives s^k λ³/(s+λ)³ of sampled signals."""

    def __init__(self, Ts: float) -> None:
        from scipy import signal

        self.Ts = Ts
        self.signal = signal

    def smooth(self, x: Array, k: int) -> Array:
        """Of a continuous signal sampled (first-order hold)."""
        return self._filter(x, k, "foh", BANDWIDTH)

    def held(self, x: Array, k: int) -> Array:
        """Of a signal held between samples (zero-order hold): the voltage, a sign."""
        return self._filter(x, k, "zoh", BANDWIDTH)

    def speed(self, theta: Array) -> Array:
        """θ̇, smoothed forwards and backwards (no delay: the record is whole), for its sign
        and size only."""
        b, a = self.signal.butter(2, SPEED_FILTER / (np.pi / self.Ts))
        smooth = self.signal.filtfilt(b, a, np.gradient(theta, self.Ts))
        return np.asarray(smooth, dtype=np.float64)

    def _filter(self, x: Array, k: int, method: str, lam: float) -> Array:
        num = np.zeros(k + 1)
        num[0] = lam**3
        b, a, _ = self.signal.cont2discrete((num, np.poly([-lam] * 3)), self.Ts, method=method)
        return np.asarray(self.signal.lfilter(np.ravel(b), a, x), dtype=np.float64)


def _late(filtered: Array, d: float) -> Array:
    """A held signal's filtered version had it taken effect ``d`` (0–1) of a sample later:
    between it and itself one sample later (exact at 0 and 1, second order between)."""
    before = np.concatenate([[0.0], filtered[:-1]])
    return (1.0 - d) * filtered + d * before


def _lstsq(X: Array, y: Array) -> tuple[Array, Array, float]:
    """Least squares: the parameters, their standard deviations and the residuals' RMS."""
    scale = np.maximum(np.sqrt(np.mean(X * X, axis=0)), 1e-300)
    p, *_ = np.linalg.lstsq(X / scale, y, rcond=None)
    p = p / scale
    e = y - X @ p
    dof = max(1, X.shape[0] - X.shape[1])
    v = float(e @ e) / dof
    cov = v * np.linalg.pinv(X.T @ X)
    return p, np.sqrt(np.maximum(np.diag(cov), 0.0)), float(np.sqrt(np.mean(e * e)))


def _signals(data: IdData) -> tuple[Array, Array, Array, float]:
    if data.nu != 1 or data.ny != 2:
        raise InvalidInput(
            "output",
            list(data.output_names),
            "one input (the voltage u) and two outputs, the servo angle θ then the link "
            "deflection α: a link model is the flexible link's",
        )
    if data.trend != "none":
        raise InvalidInput(
            "detrend",
            data.trend,
            "none for a link model: the dead zone and friction act on the voltage and speed "
            "as they are, not on their deviations from a mean",
        )
    if data.Ts > MAX_TS:
        raise InvalidInput(
            "Ts",
            data.Ts,
            f"at most {MAX_TS:g} s for a link model: its filter ({BANDWIDTH:g} rad/s) must be "
            "far below the Nyquist frequency",
        )
    return data.u[:, 0], data.y[:, 0], data.y[:, 1], data.Ts


def _model(p: LinkParameters, data: IdData) -> LinearModel:
    """The linear part (no friction, no dead zone) in states θ, α_m, θ̇, α̇_m, held at
    ``data``'s sample time; its noise variance that of its simulation's error on ``data``."""
    from scipy import signal

    sig = p.sigma
    A = np.array(
        [
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [0.0, p.a / sig, -p.c, p.beta / sig],
            [0.0, -(p.a + p.b), sig * p.c, -(p.beta + p.beta_l)],
        ]
    )
    B = np.array([[0.0], [0.0], [p.g], [-sig * p.g]])
    C = np.eye(2, 4)
    Ad, Bd, *_ = signal.cont2discrete((A, B, C, np.zeros((2, 1))), data.Ts, method="zoh")
    x0 = np.array([data.y[0, 0], data.y[0, 1], 0.0, 0.0])
    _, y, _ = signal.dlsim((Ad, Bd, C, np.zeros((2, 1)), data.Ts), data.u, x0=x0)
    e = data.y - y
    return LinearModel(
        A=Ad,
        B=Bd,
        C=C,
        D=np.zeros((2, 1)),
        K=np.zeros((4, 2)),
        Ts=data.Ts,
        noise_variance=np.cov(e.T) if np.all(np.isfinite(e)) else np.eye(2),
        parameters=p,
    )
