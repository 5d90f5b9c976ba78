"""Verdicts in plain words on identification data and on each model, each with what to
change (as MATLAB's ``advice``, ``feedback`` and ``pexcit``; Ljung 1999, ch. 13–16).

On the data, before any fit is believed: feedback from the output to the input, how many
parameters the input can excite (persistence of excitation), the signal-to-noise ratio,
quantisation, the delay and whether the record is long enough for the models asked (and,
for the two-stage method, how much of the input the references explain). The
verdicts on a model are :mod:`elab.ident.modeladvice`'s.

A verdict's ``level`` is ``good``, ``caution`` (usable, with the caveat said) or ``poor``
(do not design on it as it is); a model's level is its worst verdict's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from elab.ident.data import IdData
from elab.ident.nonparametric import Correlation

Array = NDArray[np.float64]
Level = Literal["good", "caution", "poor"]
RANK: dict[Level, int] = {"good": 0, "caution": 1, "poor": 2}

ADVICE_ROWS = 200_000  # samples the regressions of the data's verdicts use, at most
FEEDBACK_LAGS = 10  # past samples of u and y in the feedback test
FEEDBACK_SHARE = 0.02  # of the input's unpredicted variance the outputs explain
PE_TOLERANCE = 1e-3  # of the input covariance's largest eigenvalue: not excited below
PE_MAX = 40  # the largest order of excitation looked for
SNR_ORDER = 10  # the ARX model whose residual stands for the noise
SNR_GOOD_DB, SNR_POOR_DB = 20.0, 10.0
LEVELS_FEW = 100  # output levels over its range: quantised
PARAMETERS_GOOD, PARAMETERS_POOR = 10, 3  # samples per parameter
EXPLAINED_GOOD, EXPLAINED_POOR = 0.5, 0.1  # of an input's variance, by the references


@dataclass(frozen=True)
class Verdict:
    """One finding: ``topic`` (``feedback``, ``excitation``, ``noise``, ``quantisation``,
    ``delay``, ``length``, ``order_search``, ``two_stage``; for a model ``stability``,
    ``integrator``, ``fit``, ``residuals``, ``order``, ``physics``), its ``level``, what
    was found and what to change (``advice``, ``None`` when nothing needs to)."""

    topic: str
    level: Level
    finding: str
    advice: str | None = None


def graded(topic: str, value: float, good: float, poor: float, found: str, fix: str) -> Verdict:
    """A verdict on a figure where more is better: ``good`` from ``good`` on, ``poor``
    below ``poor``, a caution between (with ``fix``, what to change)."""
    if value >= good:
        return Verdict(topic, "good", found)
    return Verdict(topic, "poor" if value < poor else "caution", found, fix)


def worst(verdicts: tuple[Verdict, ...]) -> Level:
    """The worst level among ``verdicts`` (``good`` for none)."""
    return max((v.level for v in verdicts), key=RANK.__getitem__, default="good")


def on_data(
    ze: IdData,
    parameters: int,
    order: int,
    correlation: Correlation | None,
    closed_loop: bool | None = None,
    recorded: IdData | None = None,
    staged: Staged | None = None,
    *,
    indirect: bool = False,
) -> tuple[Verdict, ...]:
    """The estimation data ``ze`` (as detrended) for models of up to ``parameters``
    parameters per output and a dynamic ``order`` (0: none asked); ``correlation``: its
    correlation analysis, if made; ``closed_loop``: how the data were recorded, where
    the source knows (a run), else found from the data; ``recorded``: the data as
    recorded, before resampling smoothed its steps (quantisation is judged on them);
    ``staged``: the two-stage method's first stage, when ``ze``'s inputs are its
    prediction from the references (no noise is fed back into them); ``indirect``: the
    models were fitted to the loop from its external input (the indirect method)."""
    extra: list[Verdict] = []
    if indirect:
        fb = feedback(ze)
        said = Verdict(
            "feedback",
            "good",
            f"the input depends on past outputs ({100 * fb:.0f} % of its unpredicted "
            "variance), as in closed loop; the indirect method fitted the loop from its "
            "external input w = u + C y, which carries no fed-back noise, and solved for "
            "the plant with the known controller. Correlation and spectral analysis from u "
            "still show the controller as much as the plant",
        )
    elif staged is not None:
        fb, said = 0.0, _staged_feedback(staged)
        extra.append(_explained(staged))
    elif closed_loop is False:  # the source knows: an input deterministic enough (a PRBS)
        fb = 0.0  # is "predicted" by an integrating output's memory of its whole past
        said = Verdict("feedback", "good", "recorded in open loop (the run had no controller)")
    else:
        fb = feedback(ze)
        said = _feedback(fb, closed_loop)
    closed = fb > FEEDBACK_SHARE if closed_loop is None or staged or indirect else closed_loop
    out = [
        said,
        *extra,
        _excitation(ze, order),
        _noise(ze),
        *_quantisation(recorded or ze),
        *_delay(correlation, closed),
    ]
    if parameters:
        out.append(_length(ze.N, parameters))
    return tuple(v for v in out if v is not None)


def feedback(z: IdData, lags: int = FEEDBACK_LAGS) -> float:
    """The largest share, over the inputs, of an input's variance not predicted by its
    own past that the outputs (now and ``lags`` samples back) predict, by least squares;
    0 where that share is not significant (F test at 0.1 %). About 0 in open loop, large
    where a controller makes the input from the output."""
    from scipy.special import fdtrc  # F's survival function (scipy.stats: 0.4 s to import)

    z = _window(z)
    rows = z.N - lags
    added = (lags + 1) * z.ny
    if rows <= 4 * (lags + added):
        return 0.0
    share = 0.0
    for j in range(z.nu):
        u = z.u[lags:, j]
        own = _lagged(z.u[:, j : j + 1], lags)
        both = np.hstack([own, _lagged(z.y, lags + 1, include_now=True)])
        rss_own = _rss(own, u)
        if rss_own <= 1e-12 * float(u @ u):  # the input is its own past: nothing to test
            continue
        rss_both = _rss(both, u)
        dof = rows - both.shape[1]
        ratio = (rss_own - rss_both) / added / max(rss_both / dof, 1e-300)
        if fdtrc(added, dof, ratio) < 0.001:
            share = max(share, 1.0 - rss_both / rss_own)
    return share


def excitation_order(u: Array, most: int = PE_MAX) -> int:
    """The order of persistent excitation of ``u`` (N, nu): the largest n ≤ ``most`` whose
    n-lag covariance matrix has no eigenvalue below :data:`PE_TOLERANCE` of its largest
    (MATLAB's ``pexcit``). A step excites about 1, a sine 2, a PRBS or white noise all.
    Every n uses the same rows, t = most−1 … N−1 of the first :data:`ADVICE_ROWS`, so the
    largest matrix is built once, a block of lagged products at a time (with products
    padded by zeros beyond the record, a mean-removed step's ends looked like 5 orders
    of excitation)."""
    x = u[:ADVICE_ROWS] - u[:ADVICE_ROWS].mean(axis=0)
    N, nu = x.shape
    most = min(most, max((N - 1) // 2, 0))
    if most == 0:
        return 0
    R = np.empty((most * nu, most * nu))
    for a in range(most):
        xa = x[most - 1 - a : N - a]
        for b in range(a, most):
            block = xa.T @ x[most - 1 - b : N - b] / (N - most + 1)
            R[a * nu : (a + 1) * nu, b * nu : (b + 1) * nu] = block
            R[b * nu : (b + 1) * nu, a * nu : (a + 1) * nu] = block.T
    found = 0
    for n in range(1, most + 1):
        eig = np.linalg.eigvalsh(R[: n * nu, : n * nu])
        if eig[-1] <= 0 or eig[0] < PE_TOLERANCE * eig[-1]:
            break
        found = n
    return found


def snr_db(z: IdData, order: int = SNR_ORDER) -> float | None:
    """The output's signal-to-noise ratio in dB, the noise being the residual of an ARX
    model of ``order`` (na = nb = order, nk = 1) on ``z``: the worst output. ``None`` where
    the record is too short for that model."""
    z = _window(z)
    n = min(order, max(z.N // 20, 1))
    if z.N - n <= 4 * n * (z.ny + z.nu):
        return None
    X = np.hstack([_lagged(z.y, n), _lagged(z.u, n)])
    worst_db = math.inf
    for i in range(z.ny):
        y = z.y[n:, i]
        noise = _rss(X, y) / y.size
        signal = float(np.var(y)) - noise
        if noise <= 0:
            continue
        worst_db = min(worst_db, 10 * math.log10(max(signal, 1e-300) / noise))
    return None if math.isinf(worst_db) else worst_db


@dataclass(frozen=True)
class Staged:
    """The two-stage method's first stage as the verdicts read it: the references it
    predicted the inputs from, its taps, and the share of each input's variance on the
    estimation part the prediction explains."""

    references: tuple[str, ...]
    taps: int
    explained: tuple[float, ...]
    inputs: tuple[str, ...]


def _staged_feedback(staged: Staged) -> Verdict:
    return Verdict(
        "feedback",
        "good",
        f"two-stage method: the models read the part of {', '.join(staged.inputs)} that "
        f"{', '.join(staged.references)} "
        f"{'explains' if len(staged.references) == 1 else 'explain'} ({staged.taps} taps), "
        "which carries no "
        "noise fed back by a controller: open-loop methods, correlation and spectral "
        "analysis on it describe the plant",
    )


def _explained(staged: Staged) -> Verdict:
    """How much of each input the references explain: the two-stage estimate rests on
    that part alone."""
    least = min(staged.explained)
    name = staged.inputs[staged.explained.index(least)]
    said = f"the references explain {100 * least:.0f} % of {name}'s variance on the estimation part"
    if least >= EXPLAINED_GOOD:
        return Verdict("two_stage", "good", said)
    level: Level = "poor" if least < EXPLAINED_POOR else "caution"
    return Verdict(
        "two_stage",
        level,
        f"{said}: the rest is noise fed back by the controller (or an excitation not "
        "named), and the estimate rests on the part they explain",
        "raise the excitation at the reference or the plant input so it dominates the "
        "input; or give more taps if the loop settles slowly",
    )


def _feedback(share: float, closed_loop: bool | None) -> Verdict:
    known = "the run had a controller: " if closed_loop else ""
    if share > FEEDBACK_SHARE:
        return Verdict(
            "feedback",
            "caution",
            f"{known}the input depends on past outputs ({100 * share:.0f} % of its "
            "unpredicted variance): the data were recorded in closed loop, with the "
            "output's noise fed back. Correlation and spectral analysis from the input "
            "then show the controller as much as the plant, and fits from u to y can be "
            "biased by that noise (check the model against the validation data and, for a "
            "lab plant, its physics)",
            "use the two-stage method (it estimates from the part of u the reference and "
            "excitation explain), or fit with a noise model (armax, n4sid); excite at the "
            "reference or more strongly at the plant input; or record open loop where the "
            "plant allows",
        )
    if closed_loop:
        return Verdict(
            "feedback",
            "good",
            "recorded in closed loop (the run had a controller), but the output's noise "
            f"hardly reaches the input ({100 * share:.1f} % of its unpredicted variance): "
            "fits from u to y are nearly unbiased; correlation and spectral analysis from "
            "u still describe the plant only as far as the excitation drives u",
        )
    return Verdict("feedback", "good", "no feedback from the output to the input was found")


def _excitation(ze: IdData, order: int) -> Verdict:
    pe = excitation_order(ze.u)
    need = 2 * order
    if order and pe < need:
        return Verdict(
            "excitation",
            "poor" if pe < order else "caution",
            f"the input is persistently exciting of order {pe}: it can pin down models of "
            f"about order {pe // 2}, and order {order} was asked",
            "excite with a broadband signal (a PRBS or a chirp over the plant's band), or "
            f"ask for order {max(pe // 2, 1)} or less",
        )
    return Verdict(
        "excitation",
        "good",
        f"the input is persistently exciting of order {pe}"
        + (" or more" if pe >= min(PE_MAX, (ze.N - 1) // 2) else ""),
    )


def _noise(ze: IdData) -> Verdict | None:
    db = snr_db(ze)
    if db is None:
        return None
    found = f"signal-to-noise ratio about {db:.0f} dB (the residual of an ARX model of order 10)"
    if db >= SNR_GOOD_DB:
        return Verdict("noise", "good", found)
    rms = float(np.sqrt(np.mean(ze.u**2)))
    more = 10 ** ((SNR_GOOD_DB - db) / 20)
    return Verdict(
        "noise",
        "poor" if db < SNR_POOR_DB else "caution",
        found,
        f"raise the excitation about {more:.1f}× (its RMS is {rms:.3g} now) or record "
        "longer, within the actuator's limits",
    )


def _quantisation(ze: IdData) -> list[Verdict]:
    out = []
    for j, name in enumerate(ze.output_names or [f"y{j + 1}" for j in range(ze.ny)]):
        levels = np.unique(ze.y[:, j])
        if levels.size < 3:
            continue
        step = float(np.min(np.diff(levels)))
        span = float(levels[-1] - levels[0])
        if step > 0 and span / step < LEVELS_FEW:
            out.append(
                Verdict(
                    "quantisation",
                    "caution",
                    f"{name} moves in steps of {step:.3g} ({span / step:.0f} steps over its "
                    "range): quantisation is a large share of its noise",
                    "raise the excitation so the output spans many more steps",
                )
            )
    return out


def _delay(c: Correlation | None, closed: bool) -> list[Verdict]:
    if c is None:
        return []
    if closed:
        return [
            Verdict(
                "delay",
                "caution",
                "the delay from correlation analysis is not to be trusted on closed-loop "
                "data" + ("" if c.delay is None else f" (it reads {c.delay} samples)"),
                "take the delay from an open-loop experiment or the plant's physics",
            )
        ]
    if c.delay is None:
        return [
            Verdict(
                "delay",
                "caution",
                "no delay found: no impulse-response coefficient stands out of its "
                f"±{c.band:.3g} band",
                "excite more strongly or longer",
            )
        ]
    return [
        Verdict(
            "delay",
            "good",
            f"delay {c.delay} samples: the first impulse-response coefficient outside its "
            f"±{c.band:.3g} band ({c.k_sigma:g} σ)",
        )
    ]


def _length(N: int, parameters: int) -> Verdict:
    per = N / parameters
    return graded(
        "length",
        per,
        PARAMETERS_GOOD,
        PARAMETERS_POOR,
        f"{N} estimation samples for {parameters} parameters ({per:.0f} per parameter)",
        f"record at least {PARAMETERS_GOOD * parameters} samples for the estimation part, "
        "or ask for lower orders",
    )


def _window(z: IdData) -> IdData:
    """The first :data:`ADVICE_ROWS` samples of ``z``: the feedback test and the noise's
    ARX model regress on tens of lagged columns, and two million samples of them would
    take gigabytes for a figure a tenth of them gives as well."""
    return z if z.N <= ADVICE_ROWS else z[:ADVICE_ROWS]


def _lagged(x: Array, n: int, include_now: bool = False) -> Array:
    """Rows t = n … N−1 of [x(t−1) … x(t−n)]; ``include_now``: rows t = n−1 … N−1 of
    [x(t) … x(t−n+1)]."""
    N = x.shape[0]
    if include_now:
        return np.hstack([x[n - 1 - k : N - k] for k in range(n)])
    return np.hstack([x[n - k : N - k] for k in range(1, n + 1)])


def _rss(X: Array, y: Array) -> float:
    coef = np.linalg.lstsq(X, y, rcond=None)[0]
    r = y - X @ coef
    return float(r @ r)
