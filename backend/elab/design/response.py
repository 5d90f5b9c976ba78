"""Time and frequency responses of continuous LTI systems: step, step metrics, Bode, margins."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any
from warnings import catch_warnings, simplefilter

import control as ct
import numpy as np

from elab.design._checks import Matrix, readonly
from elab.errors import InvalidInput
from elab.validate import finite_array, finite_float

_NAN = float("nan")


@dataclass(frozen=True)
class StepResponse:
    """Outputs ``y`` (ny, N) and plant input ``u`` (N,) at times ``t`` (s)."""

    t: Matrix
    y: Matrix
    u: Matrix
    outputs: tuple[str, ...]


MIN_HORIZON = 1e-6  # s: the shortest step response computed


def step_response(
    sys: ct.StateSpace,
    T: float,
    n: int = 2001,
    amplitude: float = 1.0,
    *,
    u_output: int | None = None,
) -> StepResponse:
    """Response of a continuous single-input system to a step of height ``amplitude``.

    .. math:: \\dot x = A x + B\\, a\\, \\mathbb{1}(t), \\quad y = C x + D\\, a\\, \\mathbb{1}(t),
              \\quad x(0) = 0,\\quad t \\in [0, T]

    solved exactly on ``n`` equally spaced times (python-control's ``forced_response``).

    Parameters
    ----------
    sys : control.StateSpace
        Continuous, one input.
    T : float
        Final time (s), ≥ :data:`MIN_HORIZON` (1 µs: a shorter one has no distinct times).
    n : int
        Number of time points, ≥ 2.
    amplitude : float
        Step height, in the unit of the input.
    u_output : int, optional
        Index of the output that carries the plant input (``-1`` for a loop
        from :func:`elab.design.plant_loop.closed_loop`); it is returned as
        ``u`` and left out of ``y``. ``None``: ``sys`` is the plant, ``u`` is the step.

    References
    ----------
    K. J. Åström and R. M. Murray, *Feedback Systems*, 2nd ed., 2021, §6.3.
    """
    _check_siso_input(sys, "sys")
    T = finite_float("T", T, MIN_HORIZON)
    amplitude = finite_float("amplitude", amplitude)
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise InvalidInput("n", n, "an integer ≥ 2")
    t = np.linspace(0.0, T, n)
    response = ct.forced_response(sys, t, np.full(n, amplitude), squeeze=False)
    outputs = np.asarray(response.outputs, dtype=np.float64).reshape(sys.noutputs, n)
    names = tuple(str(name) for name in sys.output_labels)
    if u_output is None:
        return StepResponse(readonly(t), readonly(outputs), readonly(np.full(n, amplitude)), names)
    if not -sys.noutputs <= u_output < sys.noutputs:
        raise InvalidInput("u_output", u_output, f"an output index of sys ({sys.noutputs} outputs)")
    keep = [i for i in range(sys.noutputs) if i != u_output % sys.noutputs]
    u = outputs[u_output].copy()
    return StepResponse(
        readonly(t), readonly(outputs[keep]), readonly(u), tuple(names[i] for i in keep)
    )


@dataclass(frozen=True)
class StepInfo:
    """Step-response metrics; NaN where undefined (e.g. a response that has not settled).

    Times in s, ``overshoot`` in percent of the steady state, values in the output's unit.
    """

    rise_time: float
    settling_time: float
    overshoot: float
    peak: float
    peak_time: float
    steady_state: float
    steady_state_error: float


def step_info(
    t: Any,
    y: Any,
    reference: float = 1.0,
    *,
    settling: float = 0.02,
    rise: tuple[float, float] = (0.1, 0.9),
) -> StepInfo:
    """Rise time, settling time, overshoot, peak and steady state of a sampled step response.

    With :math:`y_\\infty` the final sample (only if the last 5 % of the samples
    vary by less than ``settling`` :math:`\\cdot |r|`, else NaN) and
    :math:`\\sigma = \\operatorname{sign} y_\\infty`:

    .. math::
        t_r = t_{\\min\\{k:\\ \\sigma (y_k - h y_\\infty) \\ge 0\\}}
            - t_{\\min\\{k:\\ \\sigma (y_k - l y_\\infty) \\ge 0\\}},
        \\qquad (l, h) = \\text{rise}

        t_s = t_{k^*},\\ k^* = 1 + \\max\\{k : |y_k / y_\\infty - 1| \\ge \\text{settling}\\},
        \\qquad M_p = 100 \\max\\Big(0, \\frac{\\max_k \\sigma y_k - |y_\\infty|}{|y_\\infty|}\\Big)

    and :math:`e_{ss} = r - y_\\infty`. The peak is the sample of largest magnitude.
    Sample-based, as python-control's ``step_info``.

    References
    ----------
    K. Ogata, *Modern Control Engineering*, 5th ed., 2010, §5-3.
    """
    t = finite_array("t", t, (None,))
    y = finite_array("y", y, (t.size,))
    reference = finite_float("reference", reference)
    settling = finite_float("settling", settling, 0.0, 1.0, lo_open=True)
    low, high = (finite_float("rise", r, 0.0, 1.0) for r in rise)
    if t.size < 2 or np.any(np.diff(t) <= 0) or low >= high:
        raise InvalidInput(
            "t, rise", (t.size, rise), "≥ 2 strictly increasing times and rise limits low < high"
        )
    k_peak = int(np.argmax(np.abs(y)))
    final = _final_value(y, reference, settling)
    if np.isnan(final) or final == 0.0:
        return StepInfo(
            _NAN, _NAN, _NAN, float(y[k_peak]), float(t[k_peak]), final, reference - final
        )
    sign = np.sign(final)
    k_low, k_high = (int(np.argmax(sign * (y - h * final) >= 0)) for h in (low, high))
    rise_time = t[k_high] - t[k_low]
    outside = np.flatnonzero(np.abs(y / final - 1.0) >= settling)
    k_settled = 0 if outside.size == 0 else int(outside[-1]) + 1
    settling_time = float(t[k_settled]) if k_settled < t.size else _NAN
    overshoot = 100.0 * max(0.0, (float(np.max(sign * y)) - abs(final)) / abs(final))
    return StepInfo(
        float(rise_time),
        settling_time,
        overshoot,
        float(y[k_peak]),
        float(t[k_peak]),
        final,
        reference - final,
    )


def _final_value(y: Matrix, reference: float, settling: float) -> float:
    tail = y[min(int(0.95 * y.size), y.size - 2) :]
    scale = abs(reference) if reference != 0 else float(np.max(np.abs(y)))
    return float(y[-1]) if np.ptp(tail) <= settling * scale else _NAN


@dataclass(frozen=True)
class Bode:
    """Frequency response of each output: magnitude (dB) and unwrapped phase (deg)."""

    omega: Matrix
    hz: Matrix
    mag_db: Matrix
    phase_deg: Matrix
    outputs: tuple[str, ...]


def bode(sys: ct.StateSpace | ct.TransferFunction, omega: Any = None, n: int = 500) -> Bode:
    """Bode data :math:`G(j\\omega)` from the single input to every output.

    .. math:: |G|_{\\mathrm{dB}} = 20 \\log_{10} |G(j\\omega)|, \\qquad
              \\angle G = \\operatorname{unwrap}\\big(\\arg G(j\\omega)\\big) \\cdot 180/\\pi

    The default grid has ``n`` log-spaced points from a hundredth of the smallest
    to a hundred times the largest nonzero :math:`|p|` or :math:`|z|` (poles,
    and zeros of each output; 0.01 to 100 rad/s if there are none).

    References
    ----------
    K. J. Åström and R. M. Murray, *Feedback Systems*, 2nd ed., 2021, §9.2.
    """
    _check_siso_input(sys, "sys")
    if omega is None:
        if isinstance(n, bool) or not isinstance(n, int) or n < 2:
            raise InvalidInput("n", n, "an integer ≥ 2")
        omega = _default_grid(sys, n)
    omega = finite_array("omega", omega, (None,))
    if np.any(omega <= 0):
        raise InvalidInput("omega", omega, "positive frequencies (rad/s)")
    response = ct.frequency_response(sys, omega, squeeze=False)
    G = np.asarray(response.complex, dtype=np.complex128)[:, 0, :]
    with np.errstate(divide="ignore"):  # G = 0 is -inf dB
        mag_db = 20.0 * np.log10(np.abs(G))
    phase_deg = np.degrees(np.unwrap(np.angle(G), axis=1))
    names = tuple(str(name) for name in sys.output_labels)
    return Bode(
        readonly(omega), readonly(omega / (2 * np.pi)), readonly(mag_db), readonly(phase_deg), names
    )


def _default_grid(sys: Any, n: int) -> Matrix:
    roots = [np.asarray(sys.poles(), dtype=np.complex128)]
    roots += [np.asarray(sys[i, 0].zeros(), dtype=np.complex128) for i in range(sys.noutputs)]
    size = np.abs(np.concatenate(roots))
    size = size[np.isfinite(size)]
    size = size[size > 1e-9 * np.max(size, initial=1.0)]
    low, high = (size.min(), size.max()) if size.size else (1.0, 1.0)
    return np.logspace(np.log10(low) - 2, np.log10(high) + 2, n)


@dataclass(frozen=True)
class Margins:
    """Gain margin (dB) at the phase crossover, phase margin (deg) at the gain crossover.

    Crossover frequencies in rad/s; a margin with no crossover is ``inf`` and
    its frequency NaN.
    """

    gain_margin_db: float
    phase_margin_deg: float
    gain_crossover: float
    phase_crossover: float


def margins(L: ct.TransferFunction | ct.StateSpace) -> Margins:
    """Stability margins of a SISO loop transfer :math:`L(s)` (negative feedback).

    .. math:: |L(j\\omega_{gc})| = 1,\\ \\varphi_m = 180° + \\angle L(j\\omega_{gc});
              \\qquad \\angle L(j\\omega_{pc}) = -180°,\\
              g_m = -20 \\log_{10} |L(j\\omega_{pc})|\\ \\text{dB}

    (python-control's ``stability_margins``; the smallest margins when there are several).
    ArithmeticError when the loop's numbers overflow on the way.

    References
    ----------
    K. J. Åström and R. M. Murray, *Feedback Systems*, 2nd ed., 2021, §10.3.
    """
    if L.ninputs != 1 or L.noutputs != 1:
        raise InvalidInput(
            "L",
            f"a {L.noutputs}×{L.ninputs} system",
            "a SISO loop transfer (one input, one output)",
        )
    try:
        with catch_warnings():  # python-control evaluates under its own errstate
            simplefilter("ignore", RuntimeWarning)  # overflow: seen below as IndexError
            gm, pm, _, wpc, wgc, _ = ct.stability_margins(L)
    except IndexError:  # python-control 0.10 indexes an empty crossover list
        raise ArithmeticError(  # when L's polynomials overflow (a gain of 1e111 and more)
            "the loop's frequency response is not finite: its margins cannot be computed"
        ) from None
    with np.errstate(divide="ignore"):  # gm = 0 is -inf dB
        gm_db = float(20.0 * np.log10(gm)) if np.isfinite(gm) else float(gm)
    return Margins(gm_db, float(pm), float(wgc), float(wpc))


def _check_siso_input(sys: Any, field: str) -> None:
    if not isinstance(sys, ct.LTI) or not sys.isctime() or sys.ninputs != 1:
        raise InvalidInput(field, sys, "a continuous LTI system with one input")


def default_horizon(eigenvalues: Any, time_constants: float = 10.0) -> float:
    """A step-response horizon (s): ``time_constants`` of the slowest stable pole,
    10 s when no pole is stable, at most 600 s."""
    re = -np.real(np.asarray(eigenvalues))
    re = re[re > 1e-9]
    return float(min(600.0, time_constants / re.min())) if re.size else 10.0
