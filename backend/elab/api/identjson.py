"""An identification's results (:class:`elab.ident.results.Result`) as the wire's
:class:`~elab.api.schemas.IdentOut` JSON: what ``POST /api/v1/ident`` answers and
``elab identify --json`` prints. The one place that JSON is made.

Plotted series (the data, the models' simulations and predictions) are thinned to at
most :data:`MAX_POINTS` points each, every k-th sample; numbers that are not finite (a
fit of −∞ on a constant output) become ``null``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal, assert_never

import numpy as np
from numpy.typing import NDArray

from elab.api import schemas as s
from elab.errors import InvalidInput
from elab.ident import IdData
from elab.ident import workflow as wf
from elab.ident.advice import Verdict
from elab.ident.closedloop import References
from elab.ident.nonparametric import Correlation, SineResponse, Spectrum
from elab.ident.parameters import (
    ArmaxParameters,
    ArxParameters,
    LinkParameters,
    MimoArxParameters,
    ModelParameters,
    N4sidParameters,
    OeParameters,
)
from elab.ident.results import AnalysedData, ArxOrderSearch, Fits, ModelResult, Result
from elab.ident.subspace import OrderChoice
from elab.ident.validation import Residuals

Array = NDArray[np.float64]
MAX_POINTS = 5000
Num = float | None
#: a model parameter as the wire takes it (``IdentModelOut.parameters``)
Parameter = list[Num] | list[list[Num]] | bool | int | Num | str | dict[str, Num]
Kind = Literal["arx", "armax", "oe", "n4sid", "link"]


def identify(
    data: IdData,
    plan: wf.Plan,
    validation: IdData | None = None,
    references: References | None = None,
    progress: wf.Progress | None = None,
) -> str:
    """:func:`elab.ident.workflow.run` and :func:`ident_json` (one job of the server's
    identification workers: the JSON is written there, not in the web process). The
    references the two-stage method refuses are the request's ``data.reference``."""
    try:
        return ident_json(wf.run(data, plan, progress, validation, references))
    except InvalidInput as exc:
        if exc.field != "reference":
            raise
        raise InvalidInput("data.reference", exc.value, exc.allowed) from None


def ident_json(result: Result) -> str:
    """``result`` as :class:`~elab.api.schemas.IdentOut` JSON."""
    return ident_out(result).model_dump_json()


def ident_out(result: Result) -> s.IdentOut:
    return s.IdentOut(
        data=_data(result.data),
        analyses=_analyses(result),
        models=[_model(m) for m in result.models],
        notes=list(result.notes),
        verdicts=[_verdict(v) for v in result.verdicts],
    )


def _verdict(v: Verdict) -> s.VerdictOut:
    return s.VerdictOut(topic=v.topic, level=v.level, finding=v.finding, advice=v.advice)


def _data(d: AnalysedData) -> s.IdentDataOut:
    z = d.z
    step = max(1, math.ceil(z.N / MAX_POINTS))
    return s.IdentDataOut(
        N=z.N,
        Ts=z.Ts,
        estimation=d.estimation,
        validation=d.validation,
        step=step,
        trend=z.trend,
        t=z.t[::step].tolist(),
        u=z.u[::step].T.tolist(),
        y=z.y[::step].T.tolist(),
        input_names=list(z.input_names),
        output_names=list(z.output_names),
        input_units=list(z.input_units),
        output_units=list(z.output_units),
    )


def _analyses(result: Result) -> s.AnalysesOut:
    """The analyses; one output and one input have one ARX search (``arx_search``), more
    channels one per output (``arx_search_outputs``)."""
    a, z = result.analyses, result.data.z
    searches = [_search(x) for x in a.arx_search]
    siso = z.ny == 1 and z.nu == 1
    return s.AnalysesOut(
        correlation=None if a.correlation is None else _correlation(a.correlation, z.Ts),
        spectral=None if a.spectral is None else _spectral(a.spectral),
        sine=None if a.sine is None else _sine(a.sine),
        arx_search=searches[0] if siso and searches else None,
        arx_search_outputs=searches if searches and not siso else None,
        n4sid_orders=None if a.n4sid_orders is None else _orders(a.n4sid_orders),
    )


def _correlation(c: Correlation, Ts: float) -> s.CorrelationOut:
    return s.CorrelationOut(
        lags=c.lags.tolist(),
        impulse=c.impulse.tolist(),
        band=[c.band] * len(c.lags),
        delay=c.delay,
        Ts=Ts,
    )


def _spectral(sp: Spectrum) -> s.SpectralOut:
    return s.SpectralOut(
        omega=sp.omega.tolist(),
        magnitude=sp.magnitude.tolist(),
        phase_deg=sp.phase_deg.tolist(),
        noise_spectrum=sp.noise.tolist(),
        window=sp.window,
    )


def _sine(r: SineResponse) -> s.SineOut:
    return s.SineOut(**dataclasses.asdict(r))


def _search(x: ArxOrderSearch) -> s.ArxSearchOut:
    return s.ArxSearchOut(
        output=x.output,
        rows=x.losses.tolist(),
        best=list(x.best),
        aic=list(x.aic),
        mdl=list(x.mdl),
    )


def _orders(o: OrderChoice) -> s.N4sidOrdersOut:
    return s.N4sidOrdersOut(
        horizon=o.horizon,
        best=o.best,
        reason=o.reason,
        orders=[
            s.OrderRow(order=r.order, loss=r.loss, mdl=r.mdl, aic=r.aic, holdout=r.holdout)
            for r in o.rows
        ],
        singular_values=o.singular_values.tolist(),
    )


def _model(r: ModelResult) -> s.IdentModelOut:
    m = r.model
    kind, orders, parameters = _structure(m.parameters)
    c = r.continuous
    return s.IdentModelOut(
        name=r.name,
        kind=kind,
        orders=orders,
        parameters=parameters,
        fit=_fit(r.fits),
        noise_variance=m.noise_variance.tolist(),
        poles=[[p.real, p.imag] for p in m.poles],
        stable=m.stable,
        ss=s.StateSpaceOut(
            A=m.A.tolist(),
            B=m.B.tolist(),
            C=m.C.tolist(),
            D=m.D.tolist(),
            K=m.K.tolist(),
            Ts=m.Ts,
        ),
        tf=[
            [s.TransferFunctionOut(num=num.tolist(), den=den.tolist()) for num, den in row]
            for row in m.transfer_functions()
        ],
        continuous=None
        if c is None
        else s.ContinuousOut(A=c.A.tolist(), B=c.B.tolist(), C=c.C.tolist(), D=c.D.tolist()),
        simulated=_thin(r.fits.validation_simulation.yhat),
        simulated_x0=_thin(r.fits.validation_simulation_x0.yhat),
        one_step=_thin(r.fits.validation_one_step.yhat),
        residuals=None if r.residuals is None else _residuals(r.residuals),
        verdicts=[_verdict(v) for v in r.verdicts],
        level=r.level,
    )


def _fit(f: Fits) -> s.FitOut:
    return s.FitOut(
        validation_simulation=f.validation_simulation.fit.tolist(),
        validation_simulation_x0=f.validation_simulation_x0.fit.tolist(),
        validation_one_step=f.validation_one_step.fit.tolist(),
        estimation_simulation=f.estimation_simulation.fit.tolist(),
        headline=f.headline_fit.fit.tolist(),
        headline_x0=f.headline.x0,
        headline_why=f.headline.why,
    )


def _residuals(r: Residuals) -> s.ResidualsOut:
    return s.ResidualsOut(
        lags=r.lags.tolist(),
        autocorrelation=r.autocorrelation.tolist(),
        cross_lags=r.cross_lags.tolist(),
        cross_correlation=r.cross_correlation.tolist(),
        bound=r.bound,
        white=r.white,
        independent=r.independent,
    )


def _descent(p: ArmaxParameters | OeParameters, **extra: Parameter) -> dict[str, Parameter]:
    """What a prediction-error fit says of itself, in this order: its loss, the descent
    (iterations, the start chosen, each start's loss), ``extra``, FPE and samples."""
    return {
        "loss": _num(p.loss),
        "iterations": p.iterations,
        "start": p.start,
        "start_losses": {k: _num(v) for k, v in p.start_losses.items()},
        **extra,
        "fpe": _num(p.fpe),
        "samples": p.samples,
    }


def _structure(
    p: ModelParameters | None,
) -> tuple[Kind, dict[str, int], dict[str, Parameter]]:
    """A model's kind, orders and parameters on the wire (docs/identification.md)."""
    match p:
        case ArxParameters():
            return (
                "arx",
                {"na": p.na, "nb": p.nb, "nk": p.nk},
                {
                    "A": _nums(p.A),
                    "B": _nums(p.B),
                    "dA": _nums(p.dA),
                    "dB": _nums(p.dB),
                    "loss": _num(p.loss),
                    "fpe": _num(p.fpe),
                    "aic": _num(p.aic),
                    "samples": p.samples,
                },
            )
        case MimoArxParameters():
            o = p.orders
            return (
                "arx",
                {"na": _one(o.na, "na"), "nb": _one(o.nb, "nb"), "nk": _one(o.nk, "nk")},
                {  # B and dB: row i·nu + j for output i, input j
                    "A": [_nums(a) for a in p.A],
                    "B": [_nums(b) for row in p.B for b in row],
                    "dA": [_nums(a) for a in p.dA],
                    "dB": [_nums(b) for row in p.dB for b in row],
                    "loss": [_num(v) for v in p.loss],
                    "fpe": [_num(v) for v in p.fpe],
                    "aic": [_num(v) for v in p.aic],
                    "samples": _nums(np.asarray(p.samples, dtype=np.float64)),  # as the wire reads
                },
            )
        case ArmaxParameters():
            return (
                "armax",
                {"na": p.na, "nb": p.nb, "nc": p.nc, "nk": p.nk},
                {
                    "A": _nums(p.A),
                    "B": _nums(p.B),
                    "C": _nums(p.C),
                    **_descent(p, c_at_margin=p.c_at_margin),
                },
            )
        case OeParameters():
            return (
                "oe",
                {"nb": p.nb, "nf": p.nf, "nk": p.nk},
                {"B": _nums(p.B), "F": _nums(p.F), **_descent(p)},
            )
        case N4sidParameters():
            choice: dict[str, Parameter] = {}
            if p.choice is not None:
                choice = {
                    "estimation_fit_as_estimated": _num(p.choice.fit_as_estimated),
                    "estimation_fit_reflected": _num(p.choice.fit_reflected),
                }
            return (
                "n4sid",
                {"n": p.order, "horizon": p.horizon},
                {
                    "singular_values": _nums(p.singular_values),
                    "x0": _nums(p.x0),
                    "bd": p.bd,
                    "stabilised": p.stabilised,
                    "reflected": [[_num(z) for z in pair] for pair in p.reflected],
                    **choice,
                    "kalman": p.kalman,
                },
            )
        case LinkParameters():
            names = ("a", "b", "c", "g", "f", "u_dead", "beta", "beta_l", "sigma")
            return (
                "link",
                {},
                {
                    **{name: _num(getattr(p, name)) for name in names},
                    "std": {name: _num(p.std[name]) for name in names},
                    "samples": p.samples,
                    "moving_samples": p.moving_samples,
                    "bandwidth": _num(p.bandwidth),
                    "residual_rms": [_num(p.residual_rms[0]), _num(p.residual_rms[1])],
                    "input_delay": _num(p.input_delay),
                },
            )
        case None:
            raise ValueError("a model without an estimator's parameters has no kind to send")
        case _:
            assert_never(p)


def _one(order: NDArray[np.int64], name: str) -> int:
    """An order the same for every channel, as the one integer the wire takes."""
    values = set(order.ravel().tolist())
    if len(values) != 1:
        raise ValueError(f"{name} differs between channels ({order.tolist()}): not on the wire")
    return int(values.pop())


def _num(x: float) -> Num:
    return x if math.isfinite(x) else None


def _nums(a: Array) -> list[Num]:
    return [_num(x) for x in a.tolist()]


def _thin(a: Array) -> list[list[Num]]:
    """Every k-th sample of ``a`` (N, channels), at most :data:`MAX_POINTS`, by channel."""
    step = max(1, math.ceil(a.shape[0] / MAX_POINTS))
    rows: list[list[Num]] = np.asarray(a[::step]).T.tolist()
    return rows
