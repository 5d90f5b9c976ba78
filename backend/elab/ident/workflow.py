"""The identification workflow of the seed's chapter, as one call: data → estimation and
validation sets → correlation, spectral and sine analysis → ARX order search and subspace
singular values → the requested models, each compared on the validation set (simulation
and one-step fit %) with its residual analysis. The API, the CLI and the browser panels
all run this, so they give the same numbers. Fit % on the validation set: simulated from
a zero initial state (as the published figures), from the best initial state, and one
step ahead; on the estimation set, simulated from the best initial state.

The result is a :class:`~elab.ident.results.Result` of frozen dataclasses, in full; the
JSON (with plotted series thinned) is made by :mod:`elab.api.identjson`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Literal, TypeVar, assert_never

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident import advice, modeladvice
from elab.ident.assess import assess, model_notes
from elab.ident.closedloop import Controller, References, plant_from_loop, stage_one
from elab.ident.data import IdData, decimated, require_varying, suspicious
from elab.ident.models import LinearModel
from elab.ident.nonparametric import cra, sine_response, spa
from elab.ident.pem import armax, oe
from elab.ident.physical import link
from elab.ident.polynomial import arx, arxstruc, selstruc, struc
from elab.ident.results import AnalysedData, Analyses, ArxOrderSearch, ModelResult, Result
from elab.ident.subspace import OrderChoice, Stable, Subspace, choose_order, decompose, n4sid

Array = NDArray[np.float64]
Progress = Callable[[str, float], None]
T = TypeVar("T")
MAX_SEARCH = 2000  # ARX structures in one order search
KINDS = {
    "arx": ("na", "nb", "nk"),
    "armax": ("na", "nb", "nc", "nk"),
    "oe": ("nb", "nf", "nk"),
    "n4sid": ("order", "horizon"),
    "link": (),
}


@dataclass(frozen=True)
class ModelRequest:
    """A model to estimate: ``kind`` with its orders (n4sid: ``order`` 0 = choose by MDL
    over ``Plan.n4sid_orders``; ``horizon`` 0 = the default)."""

    kind: Literal["arx", "armax", "oe", "n4sid", "link"]
    orders: dict[str, int]

    @property
    def name(self) -> str:
        given = [k for k in KINDS[self.kind] if self.kind != "n4sid" or self.orders.get(k)]
        return " ".join([self.kind, *(str(self.orders[k]) for k in given)])


@dataclass(frozen=True)
class Plan:
    """What to compute; ``split`` is the estimation share (the rest validates)."""

    models: tuple[ModelRequest, ...] = ()
    #: "operating_point": the channels' values at the plant's rest taken off every sample
    #: (a lab run's, :attr:`operating_point`), no trend estimated from the data
    detrend: Literal["mean", "linear", "none", "operating_point"] = "mean"
    split: float = 0.5
    correlation: bool = True
    max_lag: int = 30
    spectral: bool = True
    sine_hz: float | None = None
    arx_search: tuple[range, range, range] | None = None
    n4sid_orders: range | None = None
    horizon: int | None = None
    #: whether the data were recorded in closed loop, where the source knows (a run)
    closed_loop: bool | None = None
    #: keep every ``decimate``-th sample, anti-aliased (:meth:`IdData.decimate`)
    decimate: int = 1
    #: the plant's own model from the input to the outputs, where the source knows it
    physics: modeladvice.Physics | None = None
    #: the two-stage method's first-stage taps (``None``: the direct method): the
    #: estimation part's inputs are replaced by their prediction from the references
    two_stage: int | None = None
    #: the indirect method's known controller (u = w − C y): the models are fitted to
    #: the loop w → y and turned into the plant with it
    indirect: Controller | None = None
    #: the outputs' and the inputs' values at the plant's rest, where the source knows
    #: them (a lab run: its plant's operating point), for ``detrend="operating_point"``
    operating_point: tuple[tuple[float, ...], tuple[float, ...]] | None = None


def parse_model(text: str) -> ModelRequest:
    """``arx:4,4,3``, ``armax:2,2,2,3``, ``oe:2,2,3``, ``n4sid:4`` or ``n4sid:4,16`` or
    ``n4sid`` (order chosen from the singular values), ``link`` (the flexible link's
    physics)."""
    kind, _, rest = text.strip().partition(":")
    if kind not in KINDS:
        raise InvalidInput("model", text, f"kind:orders with kind one of {', '.join(KINDS)}")
    names = KINDS[kind]
    try:
        values = [int(v) for v in rest.split(",")] if rest else []
    except ValueError:
        raise InvalidInput("model", text, f"{kind}:{','.join(names)} (integers)") from None
    if kind == "n4sid":
        values = [*values, 0, 0][:2] if len(values) <= 2 else values
    if len(values) != len(names):
        raise InvalidInput("model", text, f"{kind}:{','.join(names)}")
    return ModelRequest(kind, dict(zip(names, values, strict=True)))  # type: ignore[arg-type]


def run(
    data: IdData,
    plan: Plan,
    progress: Progress | None = None,
    validation: IdData | None = None,
    references: References | None = None,
) -> Result:
    """Everything ``plan`` asks for on ``data`` (see the module docstring). ``validation``:
    a separate record to validate on (``data`` is then all estimation, and ``split`` is
    not used). ``references``: the signals that drove the loop, on ``data``'s samples
    (the two-stage method's, ``plan.two_stage``)."""
    report = progress or _unreported
    resampled = []
    as_recorded = data  # before resampling smooths its steps, clipping and freezes
    _check_closed_loop(data, plan, references)
    staged, predicted = None, None
    if plan.two_stage is not None and references is not None:
        # stage 1 at the recorded rate: the loop's map from its references to u is linear
        # there, not after resampling (an anti-aliasing filter's residue is not)
        predicted, staged = _stage_one(data, references.sampled(), plan.two_stage, plan, validation)
        resampled.append(_staged_note(staged))
    if plan.decimate != 1:
        data = data.decimate(plan.decimate)
        validation = None if validation is None else validation.decimate(plan.decimate)
        predicted = None if predicted is None else decimated(predicted, plan.decimate)
        resampled.append(
            f"one sample in {plan.decimate} kept after an anti-aliasing filter (no phase "
            f"shift): Ts = {data.Ts:g} s, {data.N} samples"
        )
    if predicted is not None:  # the estimation part reads the prediction
        n_est = data.N if validation is not None else _split_at(data, plan.split)
        data = replace(data, u=np.vstack([predicted[:n_est], data.u[n_est:]]))
    ze, zv = _estimation_and_validation(data, plan, validation)
    fit_on = ze  # what the models are estimated from
    if plan.indirect is not None:
        fit_on = _loop_data(data, plan, validation)
        resampled.insert(0, _indirect_note(plan.indirect, data))
    z = _joined(data, ze, zv)
    if plan.detrend == "operating_point":
        resampled.append(_rest_note(plan, data))
    unstable = _unstable_note(plan, ze.Ts)
    if unstable is not None:
        resampled.append(unstable)
    notes = suspicious(as_recorded)  # as given: detrending moves the edges
    if validation is not None:
        notes += [f"validation record: {n}" for n in suspicious(validation)]
    report("data", 0.02)
    nonparametric, skipped = _nonparametric(ze, z, plan, report)
    searches = () if plan.arx_search is None else _arx_search(ze, zv, plan.arx_search, report)
    sub, orders = _order_table(fit_on, plan, report)
    models, said = _models(ze, zv, plan, sub, orders, report, fit_on)
    parameters, order = _largest(plan, ze, orders)
    verdicts = advice.on_data(
        ze,
        parameters,
        order,
        nonparametric.correlation,
        plan.closed_loop,
        as_recorded,
        staged,
        indirect=plan.indirect is not None,
    )
    if plan.arx_search is not None:
        verdicts += tuple(_search_verdict(x, plan.arx_search) for x in searches)
    report("done", 1.0)
    return Result(
        data=AnalysedData(z, ze.N, "split" if validation is None else "record"),
        analyses=replace(nonparametric, arx_search=searches, n4sid_orders=orders),
        models=models,
        notes=(*resampled, *notes, *skipped, *said),
        verdicts=verdicts,
    )


def _check_closed_loop(data: IdData, plan: Plan, references: References | None) -> None:
    """Refuse, before anything is computed, a closed-loop method the data cannot take."""
    if plan.indirect is not None:
        if plan.two_stage is not None or plan.decimate != 1:
            raise InvalidInput(
                "indirect",
                "with two_stage" if plan.two_stage else f"with decimate {plan.decimate}",
                "one closed-loop method at a time, on every sample (the controller is given "
                "at the recorded sample time)",
            )
        if data.nu != 1 or data.ny != 1:
            raise InvalidInput(
                "indirect",
                f"{data.nu} inputs and {data.ny} outputs",
                "one input and one output (the controller is C(q) from y to u)",
            )
        for i, request in enumerate(plan.models):
            if request.kind == "link":
                raise InvalidInput(
                    f"models[{i}].kind", "link", "arx, armax, oe or n4sid for the indirect method"
                )
    if plan.two_stage is not None and references is None:
        raise InvalidInput(
            "two_stage",
            plan.two_stage,
            "the direct method (null) for data without references: name the signals that "
            "drove the loop (a file's reference columns; a run has its own)",
        )


def _loop_data(data: IdData, plan: Plan, validation: IdData | None) -> IdData:
    """The estimation part with the loop's external input w = u + C y in place of u (the
    indirect method fits the loop w → y), detrended as the measured part is."""
    assert plan.indirect is not None
    y0, u0 = _offsets(plan, data)
    w = plan.indirect.external(data.u - u0, data.y - y0) + u0  # the loop about its rest
    with_w = replace(data, u=w)
    ze_w, _ = _estimation_and_validation(with_w, plan, validation)
    return ze_w


def _rest_note(plan: Plan, data: IdData) -> str:
    y0, u0 = _offsets(plan, data)
    rest = ", ".join(
        f"{name} {value:.6g}"
        for name, value in zip((*data.output_names, *data.input_names), (*y0, *u0), strict=True)
    )
    return (
        f"the plant's rest taken off every sample ({rest}): no trend estimated from the "
        "data, so an integrating plant's record keeps its shape"
    )


def _indirect_note(controller: Controller, data: IdData) -> str:
    num = " ".join(f"{c:+.4g}" for c in controller.num)
    den = " ".join(f"{c:+.4g}" for c in controller.den)
    return (
        f"indirect method: the models were fitted to the loop from w = u + C(q) y to "
        f"{', '.join(data.output_names)} (C = [{num}] / [{den}] in q⁻¹, at rest before the "
        "first sample) and turned into the plant with C; fits and residuals are the "
        "plant's, on the measured u"
    )


def _stage_one(
    data: IdData, references: References, taps: int, plan: Plan, validation: IdData | None
) -> tuple[Array, advice.Staged]:
    """The two-stage method's first stage on ``data``: its inputs predicted from the
    ``references`` by a FIR of ``taps`` taps fitted on the estimation part (all of
    ``data`` when a separate ``validation`` record validates). The validation part keeps
    the measured inputs, on which a plant model is judged. References that do not vary
    over the estimation part are left out."""
    values = references.values
    if values.ndim != 2 or values.shape[0] != data.N:
        raise InvalidInput(
            "reference",
            f"shape {values.shape}",
            f"one row per sample of the data ({data.N}), a column per reference",
        )
    n_est = data.N if validation is not None else _split_at(data, plan.split)
    varying = [i for i in range(values.shape[1]) if np.any(values[:n_est, i] != values[0, i])]
    if not varying:
        raise InvalidInput(
            "reference",
            ", ".join(references.names),
            "a reference or excitation that varies over the estimation part (the two-stage "
            "method predicts the input from it)",
        )
    try:
        u, explained = stage_one(data.u, values[:, varying], taps, n_est)
    except InvalidInput as exc:
        field = "two_stage" if exc.field == "taps" else "reference"
        raise InvalidInput(field, exc.value, exc.allowed) from None
    staged = advice.Staged(
        references=tuple(references.names[i] for i in varying),
        taps=taps,
        explained=tuple(float(x) for x in explained),
        inputs=data.input_names,
    )
    return u, staged


def _split_at(data: IdData, split: float) -> int:
    """The estimation part's length for ``split`` (as :meth:`IdData.split` cuts)."""
    if not 0 < split < 1:
        raise InvalidInput("split", split, "a fraction in (0, 1): the estimation share")
    return round(float(split) * data.N)


def _staged_note(staged: advice.Staged) -> str:
    shares = ", ".join(
        f"{name} {100 * x:.0f} %" for name, x in zip(staged.inputs, staged.explained, strict=True)
    )
    return (
        f"two-stage method: the estimation part's {', '.join(staged.inputs)} replaced by its "
        f"prediction from {', '.join(staged.references)} (a FIR of {staged.taps} taps at the "
        f"recorded sample time and a constant, fitted there; variance explained: {shares}); "
        "the analyses and models estimate from it, the validation part keeps the measured "
        "input"
    )


def _top(orders: OrderChoice | None) -> int:
    """The highest order the subspace order table searched (0: no table)."""
    return max((row.order for row in orders.rows), default=0) if orders is not None else 0


def _largest(plan: Plan, ze: IdData, orders: OrderChoice | None) -> tuple[int, int]:
    """The most parameters per output and the highest dynamic order among the models
    asked for (an n4sid order to be chosen counts as its range's top)."""
    parameters, order = 0, 0
    for r in plan.models:
        o = r.orders
        match r.kind:
            case "arx":
                p, n = o["na"] + o["nb"] * ze.nu, max(o["na"], o["nb"])
            case "armax":
                p, n = o["na"] + o["nb"] + o["nc"], max(o["na"], o["nb"])
            case "oe":
                p, n = o["nb"] + o["nf"], max(o["nf"], o["nb"])
            case "n4sid":
                n = o.get("order") or _top(orders)
                p = n * (ze.nu + ze.ny) + ze.nu * ze.ny
            case "link":
                p, n = 8, 3
            case _:
                assert_never(r.kind)
        parameters, order = max(parameters, p), max(order, n)
    return parameters, order


def _search_verdict(x: ArxOrderSearch, ranges: tuple[range, range, range]) -> advice.Verdict:
    """The ARX order search's choice, at the top of a range or inside them."""
    na, nb, nk = x.best
    top = [
        name
        for name, v, r in zip(("na", "nb", "nk"), x.best, ranges, strict=True)
        if len(r) > 1 and v == max(r)
    ]
    if top:
        return advice.Verdict(
            "order_search",
            "caution",
            f"the ARX search for {x.output} chose [{na} {nb} {nk}], at the top of its range "
            f"in {' and '.join(top)}: a corner of the search is no answer",
            "widen the range; if it climbs again, suspect feedback, a drift or nonlinearity "
            "rather than a high order",
        )
    return advice.Verdict(
        "order_search", "good", f"the ARX search for {x.output} chose [{na} {nb} {nk}]"
    )


def _unreported(stage: str, done: float) -> None:
    pass


def _estimation_and_validation(
    data: IdData, plan: Plan, validation: IdData | None
) -> tuple[IdData, IdData]:
    """The estimation and validation parts (split, or ``data`` and the ``validation``
    record), detrended: each part by its own trend when split, as MATLAB's standard
    experiment; a separate record by the estimation record's means (a line does not
    carry over: each record its own)."""
    if validation is None:
        if not 0 < plan.split < 1:
            raise InvalidInput("split", plan.split, "a fraction in (0, 1): the estimation share")
        ze, zv = data.split(float(plan.split))
    else:
        ze, zv = data, _same_channels(data, validation)
    require_varying(ze.y, list(data.output_names), "estimation part")
    if plan.detrend == "operating_point":
        y0, u0 = _offsets(plan, data)
        ze = replace(ze, y=ze.y - y0, u=ze.u - u0)
        zv = replace(zv, y=zv.y - y0, u=zv.u - u0)
    elif plan.detrend != "none" and validation is None:
        ze, zv = ze.detrend(plan.detrend), zv.detrend(plan.detrend)
    elif plan.detrend == "mean":
        y0, u0 = ze.y.mean(axis=0), ze.u.mean(axis=0)
        ze = replace(ze, y=ze.y - y0, u=ze.u - u0, trend="mean")
        zv = replace(zv, y=zv.y - y0, u=zv.u - u0, trend="mean")
    elif plan.detrend == "linear":
        ze, zv = ze.detrend("linear"), zv.detrend("linear")
    return ze, zv


def _offsets(plan: Plan, data: IdData) -> tuple[Array, Array]:
    """The outputs' and inputs' values at the plant's rest with ``detrend="operating_point"``
    (zeros otherwise)."""
    if plan.detrend != "operating_point":
        return np.zeros(data.ny), np.zeros(data.nu)
    if plan.operating_point is None:
        raise InvalidInput(
            "detrend",
            "operating_point",
            "'mean', 'linear' or 'none' for data whose plant's rest is not known (a file's); "
            "'operating_point' takes a lab run's plant's rest off its channels",
        )
    y0, u0 = (np.asarray(v, dtype=np.float64) for v in plan.operating_point)
    if y0.shape != (data.ny,) or u0.shape != (data.nu,):
        raise InvalidInput(
            "operating_point",
            f"{y0.size} outputs and {u0.size} inputs",
            f"one value per channel: {data.ny} outputs and {data.nu} inputs",
        )
    return y0, u0


def _joined(data: IdData, ze: IdData, zv: IdData) -> IdData:
    """The estimation samples then the validation samples, as one record on ``data``'s
    time axis."""
    return IdData(
        np.vstack([ze.y, zv.y]),
        np.vstack([ze.u, zv.u]),
        data.Ts,
        data.output_names,
        data.input_names,
        data.output_units,
        data.input_units,
        data.k0,
        ze.trend,
    )


def _nonparametric(
    ze: IdData, z: IdData, plan: Plan, report: Progress
) -> tuple[Analyses, list[str]]:
    """Correlation and spectral analysis of the estimation part, sine analysis of all the
    data: one input and one output only. An analysis the data refuse is skipped with a
    note when the plan asks for more than it (else its refusal is the answer)."""
    if z.ny != 1 or z.nu != 1:
        if plan.correlation or plan.spectral or plan.sine_hz:
            return Analyses(), [
                f"{z.ny} outputs and {z.nu} inputs: correlation, spectral and sine "
                "analysis need one of each; they were skipped"
            ]
        return Analyses(), []
    asked_more = bool(plan.models or plan.arx_search or plan.n4sid_orders or plan.sine_hz)
    correlation, spectral, notes = None, None, []
    if plan.correlation:
        lags = min(plan.max_lag, max(ze.N // 4 - 12, 1))
        correlation, note = _unless_refused(
            "correlation analysis", lambda: cra(ze, max_lag=lags), asked_more
        )
        notes += note
        report("correlation", 0.05)
    if plan.spectral:
        spectral, note = _unless_refused("spectral analysis", lambda: spa(ze), asked_more)
        notes += note
        report("spectral", 0.08)
    sine = None if plan.sine_hz is None else sine_response(z, plan.sine_hz)
    return Analyses(correlation, spectral, sine), notes


def _unless_refused(
    what: str, analysis: Callable[[], T], optional: bool
) -> tuple[T | None, list[str]]:
    """``analysis()``; if the data refuse it and it is ``optional``, None and a note."""
    try:
        return analysis(), []
    except InvalidInput as exc:
        if not optional:
            raise
        return None, [f"{what} skipped: {exc}"]


def _order_table(
    ze: IdData, plan: Plan, report: Progress
) -> tuple[Subspace | None, OrderChoice | None]:
    """The subspace decomposition and its order table, when asked for or needed (an
    n4sid model whose order is to be chosen)."""
    chosen = [m for m in plan.models if m.kind == "n4sid" and not m.orders.get("order")]
    if plan.n4sid_orders is None and not chosen:
        return None, None
    report("subspace: the singular values of the data", 0.5)
    sub = decompose(ze, plan.horizon)
    choice = choose_order(
        sub,
        plan.n4sid_orders or range(1, min(10, sub.max_order) + 1),
        stable=_stable_policy(plan, ze.Ts),
    )
    report("subspace", 0.6)
    return sub, choice


def _models(
    ze: IdData,
    zv: IdData,
    plan: Plan,
    sub: Subspace | None,
    orders: OrderChoice | None,
    report: Progress,
    fit_on: IdData | None = None,
) -> tuple[tuple[ModelResult, ...], list[str]]:
    """Each requested model, estimated (from ``fit_on``, by default ``ze``; with the
    indirect method the loop's data, the model then turned into the plant) and assessed
    on ``ze`` and ``zv``, and what a reader must know of it."""
    flat = [zv.output_names[j] for j in range(zv.ny) if np.all(zv.y[:, j] == zv.y[0, j])]
    notes = []
    if flat and plan.models:
        notes.append(
            f"the validation part of {', '.join(flat)} is constant: fits on it are "
            "undefined (null); the estimation fits stand"
        )
    best = 0 if orders is None else orders.best
    results = []
    n = len(plan.models)
    for i, request in enumerate(plan.models):
        # said before each model, which may take seconds (ARMAX and OE: several starts)
        report(f"estimating {request.name}, model {i + 1} of {n}", 0.6 + 0.4 * i / n)
        source = ze if fit_on is None else fit_on
        model = _estimate(
            source,
            request,
            sub,
            best,
            plan.horizon,
            i,
            plan.decimate > 1,
            _stable_policy(plan, source.Ts),
        )
        name = _name(request, model)
        if plan.indirect is not None:
            model, name = plant_from_loop(model, plan.indirect), f"{name} (indirect)"
        result = assess(name, model, ze, zv)
        chosen = request.kind == "n4sid" and not request.orders.get("order")
        top = chosen and model.nx == _top(orders)
        fit = result.fits.headline_fit.fit
        fit = fit[np.isfinite(fit)]
        verdicts = modeladvice.on_model(
            model.poles,
            float(np.min(fit)) if fit.size else math.nan,
            result.fits.headline.x0,
            result.residuals,
            plan.detrend,
            top,
            _unstable_plant(plan, model.Ts),
        )
        if plan.physics is not None and model.nu == 1:
            verdicts += tuple(
                modeladvice.on_physics(_single(model, j), _row(plan.physics, j), zv.output_names[j])
                for j in range(model.ny)
            )
        results.append(replace(result, verdicts=verdicts))
        notes += model_notes(results[-1].name, model)
        report(f"model {request.name}", 0.6 + 0.4 * (i + 1) / n)
    return tuple(results), notes


def _single(m: LinearModel, j: int) -> LinearModel:
    """Output ``j`` of ``m`` alone."""
    return replace(
        m,
        C=m.C[j : j + 1],
        D=m.D[j : j + 1],
        K=m.K[:, j : j + 1],
        noise_variance=m.noise_variance[j : j + 1, j : j + 1],
        parameters=None,
    )


def _row(p: modeladvice.Physics, j: int) -> modeladvice.Physics:
    return replace(p, C=p.C[j : j + 1], D=p.D[j : j + 1])


def _name(r: ModelRequest, m: LinearModel) -> str:
    """The request's name; an n4sid model's whose order was chosen names that order."""
    return r.name if r.kind != "n4sid" or r.orders.get("order") else f"n4sid {m.nx}"


def _same_channels(data: IdData, validation: IdData) -> IdData:
    """The validation record, checked to be the same experiment's kind: the same sample
    time and channels."""
    if not math.isclose(validation.Ts, data.Ts, rel_tol=1e-9):
        raise InvalidInput(
            "validation.Ts", validation.Ts, f"the estimation record's sample time {data.Ts:g} s"
        )
    for what in ("output_names", "input_names"):
        if getattr(validation, what) != getattr(data, what):
            raise InvalidInput(
                f"validation.{what}",
                list(getattr(validation, what)),
                f"the estimation record's {', '.join(getattr(data, what))}",
            )
    return validation


def _arx_search(
    ze: IdData, zv: IdData, ranges: tuple[range, range, range], report: Progress
) -> tuple[ArxOrderSearch, ...]:
    """Each output's own search (with every input, each structure's nb and nk for all)."""
    S = struc(*ranges)
    if S.shape[0] * ze.ny > MAX_SEARCH:
        raise InvalidInput(
            "arx_search",
            f"{S.shape[0]} structures" + (f" for each of {ze.ny} outputs" if ze.ny > 1 else ""),
            f"at most {MAX_SEARCH} structures (na × nb × nk × outputs)",
        )
    delays = np.unique(S[:, 2])
    out = []
    for i in range(ze.ny):
        parts = []
        for k, nk in enumerate(delays):  # one delay at a time, to report progress
            parts.append(arxstruc(_output(ze, i), _output(zv, i), S[S[:, 2] == nk]))
            report("arx search", 0.1 + 0.4 * (i * len(delays) + k + 1) / (len(delays) * ze.ny))
        V = np.vstack(parts)
        out.append(
            ArxOrderSearch(
                output=ze.output_names[i],
                losses=V,
                best=selstruc(V, 0),
                aic=selstruc(V, "aic", zv.N),
                mdl=selstruc(V, "mdl", zv.N),
            )
        )
    return tuple(out)


def _estimate(
    ze: IdData,
    r: ModelRequest,
    sub: Subspace | None,
    best: int,
    horizon: int | None,
    i: int,
    decimated: bool = False,
    stable: Stable = "auto",
) -> LinearModel:
    o = r.orders
    if r.kind == "link" and decimated:
        raise InvalidInput(
            f"models[{i}].kind",
            r.kind,
            "another kind, or decimate 1: a link model reads speeds and the voltage's "
            "delay from every recorded sample",
        )
    if r.kind == "link" and ze.trend != "none":
        raise InvalidInput(
            f"models[{i}].kind",
            r.kind,
            "another kind, or detrend none: a link model needs the voltage and speeds as they "
            "are (the dead zone and friction act on them, not on deviations from a mean)",
        )
    if r.kind in ("armax", "oe") and (ze.ny != 1 or ze.nu != 1):
        raise InvalidInput(
            f"models[{i}].kind",
            r.kind,
            f"arx or n4sid for {ze.ny} outputs and {ze.nu} inputs "
            f"({r.kind}: one output and one input)",
        )
    try:
        match r.kind:
            case "arx":
                return arx(ze, o["na"], o["nb"], o["nk"])
            case "armax":
                return armax(ze, o["na"], o["nb"], o["nc"], o["nk"])
            case "oe":
                return oe(ze, o["nb"], o["nf"], o["nk"])
            case "n4sid":
                own = o.get("horizon") or None
                if sub is None or (own is not None and own != sub.horizon):
                    sub = decompose(ze, own or horizon)
                return n4sid(ze, o.get("order") or best, sub=sub, stable=stable)
            case "link":
                return link(ze)
            case _:
                assert_never(r.kind)
    except InvalidInput as exc:
        raise InvalidInput(f"models[{i}].{exc.field}", exc.value, exc.allowed) from None


def _unstable_plant(plan: Plan, Ts: float) -> float | None:
    """The plant's largest pole |z| at ``Ts`` where its physics (a lab run's) is unstable."""
    return None if plan.physics is None else modeladvice.unstable_pole(plan.physics, Ts)


def _stable_policy(plan: Plan, Ts: float) -> Stable:
    """Subspace's policy for poles outside the unit circle: kept where the plant's own
    physics is unstable (the default judges an estimate against its reflection by a
    simulation, in which the true unstable mode grows e⁵² over the pendulum's 10 s: the
    reflection always won), else "auto" (:func:`~elab.ident.subspace.n4sid`)."""
    return False if _unstable_plant(plan, Ts) is not None else "auto"


def _unstable_note(plan: Plan, Ts: float) -> str | None:
    pole = _unstable_plant(plan, Ts)
    if pole is None or not any(m.kind == "n4sid" for m in plan.models):
        return None
    return (
        f"the plant is unstable (its physics has a pole at |z| = {pole:.6g} at this sample "
        "time): subspace models keep their poles outside the unit circle rather than "
        "reflecting them; simulated fits, and an order chosen by them, grow with the "
        "unstable mode and do not judge a model here: give n4sid its order"
    )


def _output(z: IdData, i: int) -> IdData:
    """Output ``i`` of ``z`` with every input."""
    if z.ny == 1:
        return z
    return replace(
        z, y=z.y[:, [i]], output_names=(z.output_names[i],), output_units=(z.output_units[i],)
    )
