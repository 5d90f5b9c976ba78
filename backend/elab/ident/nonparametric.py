"""Non-parametric estimates (Ljung 1999, ch. 6): correlation analysis, as MATLAB's
``cra``, and spectral analysis, as MATLAB's ``spa``.

Correlation analysis.
The input is prewhitened by its own AR model Aᵤ(q) u = w (order ``prewhiten_order``);
filtering the output by the same Aᵤ keeps the system's impulse response g:
y_f = G u_f + v_f with u_f = w white, so

    ĝ(k) = R̂_{y_f w}(k) / R̂_w(0),   k = 0 … M,

and, if the system had no response at lag k, ĝ(k) would scatter with standard deviation
σ = √(R̂_{y_f}(0) / (N R̂_w(0))). The band ±k·σ marks the lags whose estimate is noise;
the delay estimate is the first lag outside it.

Sine analysis (:func:`sine_response`): |G| and ∠G at the frequency of a sine experiment.
"""

from __future__ import annotations

import cmath
import math
import numbers
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData, require_exciting

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Correlation:
    lags: NDArray[np.int64]
    impulse: Array
    sigma: float
    k_sigma: float
    delay: int | None

    @property
    def band(self) -> float:
        """k·σ: an impulse-response estimate within ±band is noise."""
        return self.k_sigma * self.sigma


def cra(
    data: IdData, max_lag: int = 30, prewhiten_order: int = 10, k_sigma: float = 3.0
) -> Correlation:
    """Impulse response estimate of a single-input single-output data set."""
    import scipy.signal  # here: 0.7 s of imports that ARX and n4sid models do without

    if data.ny != 1 or data.nu != 1:
        raise InvalidInput(
            "data",
            f"{data.ny} outputs, {data.nu} inputs",
            "one output and one input for correlation analysis",
        )
    if not isinstance(max_lag, int) or max_lag < 1:
        raise InvalidInput("max_lag", max_lag, "an integer ≥ 1")
    if not isinstance(prewhiten_order, int) or prewhiten_order < 0:
        raise InvalidInput("prewhiten_order", prewhiten_order, "an integer ≥ 0")
    if not k_sigma > 0:
        raise InvalidInput("k_sigma", k_sigma, "a number > 0")
    N = data.N
    if 4 * (max_lag + prewhiten_order + 1) > N:
        need = 4 * (max_lag + prewhiten_order + 1)
        raise InvalidInput(
            "data",
            f"{N} samples",
            f"at least {need} samples for {max_lag} "
            f"lags and a prewhitening order of {prewhiten_order}",
        )
    require_exciting(data.u, 1)
    u, y = data.u[:, 0], data.y[:, 0]
    a = _ar(u, prewhiten_order)
    w = scipy.signal.lfilter(a, [1.0], u)[prewhiten_order:]
    yf = scipy.signal.lfilter(a, [1.0], y)[prewhiten_order:]
    n = w.shape[0]
    rw0 = float(w @ w) / n
    g = np.array([float(yf[k:] @ w[: n - k]) / n for k in range(max_lag + 1)]) / rw0
    sigma = float(np.sqrt(float(yf @ yf) / n / (n * rw0)))
    outside = np.flatnonzero(np.abs(g) > k_sigma * sigma)
    return Correlation(
        np.arange(max_lag + 1), g, sigma, float(k_sigma), int(outside[0]) if outside.size else None
    )


def _ar(u: Array, order: int) -> Array:
    """[1, a₁ … a_n]: the least-squares AR model of ``u`` (the prewhitening filter)."""
    if order == 0:
        return np.array([1.0])
    N = u.shape[0]
    Phi = np.column_stack([-u[order - i : N - i] for i in range(1, order + 1)])
    theta, *_ = np.linalg.lstsq(Phi, u[order:], rcond=None)
    return np.asarray(np.r_[1.0, theta], dtype=np.float64)


@dataclass(frozen=True)
class Spectrum:
    """Frequency response Ĝ(e^{iωTs}) and output-noise spectrum at ``omega`` (rad/s)."""

    omega: Array
    G: NDArray[np.complex128]
    noise: Array
    window: int

    @property
    def magnitude(self) -> Array:
        return np.asarray(np.abs(self.G), dtype=np.float64)

    @property
    def phase_deg(self) -> Array:
        """∠Ĝ in degrees, unwrapped along ``omega``."""
        return np.asarray(np.degrees(np.unwrap(np.angle(self.G))), dtype=np.float64)


def spa(data: IdData, window: int | None = None, omega: Array | None = None) -> Spectrum:
    """Blackman–Tukey spectral analysis (Ljung 1999, sec. 6.4), as MATLAB's ``spa``:

            Φ̂_yu(ω) = Σ_{|τ| ≤ M} W_M(τ) R̂_yu(τ) e^{−iωτTs},  W_M(τ) = ½ (1 + cos(πτ/M)),
            Ĝ = Φ̂_yu / Φ̂_u,   Φ̂_v = Ts (Φ̂_y − |Φ̂_yu|² / Φ̂_u),

        with R̂_yu(τ) = (1/N) Σ y(t+τ) u(t), the lag window M = min(N/10, 30) by default and
        MATLAB's grid ω = k π / (128 Ts), k = 1 … 128. The noise spectrum carries MATLAB's
    factor Ts (white noise of variance λ has Φ̂_v = λ Ts), so it integrates to the variance
    over (−π/Ts, π/Ts] divided by 2π.
    """
    if data.ny != 1 or data.nu != 1:
        raise InvalidInput(
            "data",
            f"{data.ny} outputs, {data.nu} inputs",
            "one output and one input for spectral analysis",
        )
    N = data.N
    M = min(N // 10, 30) if window is None else window
    if not isinstance(M, int) or not 2 <= M < N // 2:
        raise InvalidInput("window", window, f"an integer lag window in 2 … {N // 2 - 1}")
    require_exciting(data.u, 1)
    w = np.arange(1, 129) * np.pi / 128 / data.Ts if omega is None else np.asarray(omega, float)
    if w.ndim != 1 or w.size == 0 or np.any(w <= 0) or np.any(w > np.pi / data.Ts * (1 + 1e-12)):
        raise InvalidInput("omega", "frequencies", f"in (0, π/Ts] = (0, {np.pi / data.Ts:g}] rad/s")
    y, u = data.y[:, 0], data.u[:, 0]
    tau = np.arange(-M, M + 1)
    lag_window = 0.5 * (1 + np.cos(np.pi * tau / M))

    def cov(a: Array, b: Array) -> Array:  # R_ab(τ) = (1/N) Σ a(t+τ) b(t)
        return np.array([a[k:] @ b[: N - k] if k >= 0 else a[: N + k] @ b[-k:] for k in tau]) / N

    E = np.exp(-1j * np.outer(w * data.Ts, tau))
    phi_yu = E @ (lag_window * cov(y, u))
    phi_u = (E @ (lag_window * cov(u, u))).real
    phi_y = (E @ (lag_window * cov(y, y))).real
    G = phi_yu / phi_u
    noise = data.Ts * np.maximum(phi_y - np.abs(phi_yu) ** 2 / phi_u, 0.0)
    return Spectrum(w, G, noise, M)


@dataclass(frozen=True)
class SineResponse:
    """G(e^{iωTs}) at one frequency from a sine-excited experiment."""

    frequency_hz: float
    omega: float  # rad/s
    magnitude: float
    phase_deg: float  # in (−180, 180]
    periods_used: int
    samples_used: int


def sine_response(
    data: IdData, frequency_hz: float, periods_skip: int | None = None
) -> SineResponse:
    """Frequency analysis by correlation (Ljung 1999, sec. 6.1): with u(t) = α cos(ωt·Ts)
    (any phase and offset) and the transient dropped, over a whole number of periods

        Y = (2/n) Σ y(t) e^{−iωtTs},   U = (2/n) Σ u(t) e^{−iωtTs},   Ĝ(e^{iωTs}) = Y / U,

    so |Ĝ| = |Y|/|U| and ∠Ĝ = ∠Y − ∠U; a constant offset and every harmonic of ω (a
    distortion) drop out, and noise is averaged down as 1/√n. The transient skipped is
    ``periods_skip`` periods (default: a quarter of the data rounded up to whole periods,
    at least one). When a period is not a whole number of samples, the window is the
    nearest whole number of samples, which leaves an error of order 1/n.
    """
    if data.ny != 1 or data.nu != 1:
        raise InvalidInput(
            "data",
            f"{data.ny} outputs, {data.nu} inputs",
            "one output and one input for sine analysis",
        )
    nyquist = 0.5 / data.Ts
    if (
        not isinstance(frequency_hz, numbers.Real)
        or isinstance(frequency_hz, bool)
        or not 0 < frequency_hz < nyquist
    ):
        raise InvalidInput(
            "frequency_hz",
            frequency_hz,
            f"a frequency in (0, {nyquist:g}) Hz (below Nyquist, 1/(2 Ts))",
        )
    N = data.N
    if frequency_hz * data.Ts * N < 1:  # not one period in the record
        raise InvalidInput(
            "frequency_hz",
            frequency_hz,
            f"a frequency with a whole period in the record: ≥ {1 / (N * data.Ts):g} Hz",
        )
    period = 1 / (frequency_hz * data.Ts)  # samples per period
    if periods_skip is None:
        skip = max(1, math.ceil(N / 4 / period - 1e-9))
    elif not isinstance(periods_skip, int) or isinstance(periods_skip, bool) or periods_skip < 0:
        raise InvalidInput("periods_skip", periods_skip, "an integer ≥ 0")
    else:
        skip = periods_skip
    start = math.ceil(skip * period - 1e-9)
    periods = math.floor((N - start) / period + 1e-9)
    if periods < 1:
        raise InvalidInput(
            "data",
            f"{N} samples",
            f"at least one whole period "
            f"({period:.4g} samples) after the {start} samples skipped "
            f"({skip} periods of transient)",
        )
    n = min(round(periods * period), N - start)
    omega = 2 * math.pi * frequency_hz
    t = np.arange(start, start + n)
    kernel = np.exp(-1j * omega * data.Ts * t)
    Y = 2 / n * complex(data.y[start : start + n, 0] @ kernel)
    U = 2 / n * complex(data.u[start : start + n, 0] @ kernel)
    u_rms = float(np.sqrt(np.mean(data.u[start : start + n, 0] ** 2)))
    if abs(U) <= 1e-9 * max(u_rms, 1e-300):
        raise InvalidInput(
            "u",
            f"an input without a component at {frequency_hz:g} Hz",
            "a sine at the test frequency",
        )
    G = Y / U
    return SineResponse(
        float(frequency_hz), omega, abs(G), math.degrees(cmath.phase(G)), periods, n
    )
