"""``elab identify``: models and analyses from a data file, as the server's identification
gives them (``--json``: the API's answer). Imports only the identification it runs."""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, assert_never

import numpy as np

from elab.errors import InvalidInput

if TYPE_CHECKING:
    from elab.ident.advice import Verdict
    from elab.ident.parameters import Array, ModelParameters
    from elab.ident.results import Result

ANALYSES = ("correlation", "spectral")  # elab identify --analyses


def parse_analyses(text: str | None, asked: bool) -> frozenset[str]:
    """``--analyses``: the analyses named (``all``, ``none``, or a comma-separated subset
    of :data:`ANALYSES`); not given, all of them when nothing else was ``asked`` for
    (a bare ``elab identify FILE`` shows the delay and the spectrum), else none."""
    if text is None:
        return frozenset() if asked else frozenset(ANALYSES)
    names = {n.strip() for n in text.split(",") if n.strip()}
    allowed = f"{', '.join(ANALYSES)} (comma-separated), all or none"
    if not names or not names <= {*ANALYSES, "all", "none"}:
        raise InvalidInput("--analyses", text, allowed)
    if len(names) > 1 and names & {"all", "none"}:
        raise InvalidInput("--analyses", text, allowed)
    return frozenset(ANALYSES) if names == {"all"} else frozenset(names - {"none"})


def cmd_identify(args: argparse.Namespace) -> str:
    from elab.ident import workflow as wf
    from elab.ident.files import read_table

    asked = bool(args.model or args.search or args.sine is not None)
    analyses = parse_analyses(args.analyses, asked)

    def table(name: str, field: str) -> Any:
        path = Path(name)
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise InvalidInput(field, name, f"a readable file ({exc.strerror})") from None
        return read_table(raw, "json" if path.suffix.lower() == ".json" else "csv")

    def dataset(columns: Any) -> Any:
        return columns.dataset(_names(args.input), _names(args.output), args.Ts)

    data_table = table(args.data, "data")
    data = dataset(data_table)
    validation = None if args.validation is None else dataset(table(args.validation, "validation"))
    references = None
    if args.reference:  # the two-stage method: u as the reference explains it
        from elab.ident.closedloop import References

        names = _names(args.reference)
        try:  # the reference columns of the same table, read once
            refs = data_table.dataset(names, _names(args.output), args.Ts).u
        except InvalidInput as exc:  # the columns asked for as --reference
            if exc.field != "input":
                raise
            raise InvalidInput("reference", exc.value, exc.allowed) from None
        references = References(refs, tuple(names))
    arx_search, n4sid_orders = None, None
    for text in args.search:
        kind, _, spans = text.partition(":")
        ranges = [_span(part, f"search {kind}") for part in spans.split(",") if part]
        if kind == "arx" and len(ranges) == 3:
            arx_search = (ranges[0], ranges[1], ranges[2])
        elif kind == "n4sid" and len(ranges) == 1:
            n4sid_orders = ranges[0]
        else:
            raise InvalidInput("search", text, "arx:na1-na2,nb1-nb2,nk1-nk2 or n4sid:n1-n2")
    plan = wf.Plan(
        models=tuple(wf.parse_model(m) for m in args.model),
        correlation="correlation" in analyses,
        spectral="spectral" in analyses,
        detrend=args.detrend,
        split=args.split,
        sine_hz=args.sine,
        arx_search=arx_search,
        n4sid_orders=n4sid_orders,
        horizon=args.horizon,
        decimate=args.decimate,
        two_stage=args.taps if references is not None else None,
        indirect=None if args.indirect is None else _controller(args.indirect),
    )
    result = wf.run(data, plan, validation=validation, references=references)
    if args.json:  # the API's answer, validated against the same wire model
        from elab.api.identjson import ident_json

        return ident_json(result)
    staged = [n for n in result.notes if n.startswith("two-stage")]  # said first
    rest = replace(result, notes=tuple(n for n in result.notes if n not in staged))
    return "".join(n + "\n" for n in staged) + _identify_text(data, rest)


def _controller(text: str) -> Any:
    """``--indirect NUM/DEN``: the controller's coefficients of q⁻¹."""
    from elab.ident.closedloop import Controller

    num, sep, den = text.partition("/")
    try:
        coefs = [tuple(float(c) for c in part.split(",") if c.strip()) for part in (num, den)]
    except ValueError:
        coefs = []
    if not sep or len(coefs) != 2:
        raise InvalidInput("--indirect", text, "NUM/DEN: comma-separated numbers, e.g. 0.6/1")
    try:
        return Controller(coefs[0], coefs[1])
    except InvalidInput as exc:
        raise InvalidInput("--indirect", text, exc.allowed) from None


def _names(text: str) -> list[str]:
    return [n.strip() for n in text.split(",") if n.strip()]


def _span(text: str, field: str) -> range:
    lo, sep, hi = text.partition("-")
    try:
        a, b = int(lo), int(hi) if sep else int(lo)
    except ValueError:
        raise InvalidInput(field, text, "an integer or a range such as 1-10") from None
    if a > b:
        raise InvalidInput(field, text, "a range low-high with low ≤ high")
    return range(a, b + 1)


def _identify_text(data: Any, result: Result) -> str:
    d = result.data
    z = d.z
    lines = [
        f"data: {z.N} samples at Ts = {z.Ts:g} s, inputs {', '.join(z.input_names)}"
        f", outputs {', '.join(z.output_names)}; estimation {d.estimation} samples, "
        f"validation {z.N - d.estimation}; detrend {z.trend}"
    ]
    a = result.analyses
    if a.correlation is not None:
        delay = a.correlation.delay
        lines.append(
            "correlation analysis: "
            + (
                f"delay {delay} samples"
                if delay is not None
                else "no delay found (no impulse-response coefficient is significant)"
            )
        )
    if a.spectral is not None:
        sp = a.spectral
        magnitude, omega = sp.magnitude.tolist(), sp.omega.tolist()
        peak = int(np.argmax(magnitude))
        lines.append(
            f"spectral analysis (lag window {sp.window}): |G| = {magnitude[0]:.4g} at "
            f"{omega[0]:.4g} rad/s, largest {magnitude[peak]:.4g} at "
            f"{omega[peak]:.4g} rad/s (--json: all {len(omega)} frequencies)"
        )
    for s in a.arx_search:
        best = min(s.losses.tolist(), key=lambda r: r[3])
        lines.append(
            f"ARX search for {s.output} over {len(s.losses)} structures: best [na nb nk] = "
            f"{list(s.best)} (validation loss {best[3]:.6g}); AIC {list(s.aic)}, "
            f"MDL {list(s.mdl)}"
        )
    if a.n4sid_orders is not None:
        o = a.n4sid_orders
        sv = ", ".join(f"{v:.4g}" for v in o.singular_values[:8].tolist())
        lines.append(
            f"subspace (horizon {o.horizon}): singular values {sv}, …; order {o.best}: {o.reason}"
        )
    if a.sine is not None:
        sn = a.sine
        lines.append(
            f"sine analysis at {sn.frequency_hz:g} Hz: |G| = {sn.magnitude:.4g},"
            f" phase {sn.phase_deg:.1f} deg"
        )
    for m in result.models:
        fit = m.fits
        estimated = fit.headline.x0 == "estimated"
        lines.append(
            f"{m.name}: validation fit {_pct(fit.headline_fit.fit.tolist())} (simulation, "
            f"{'estimated' if estimated else 'zero'} initial state), "
            f"{_pct(fit.validation_one_step.fit.tolist())} (one step)"
        )
        other = fit.validation_simulation if estimated else fit.validation_simulation_x0
        lines.append(
            f"  from the {'zero' if estimated else 'estimated'} "
            f"initial state: {_pct(other.fit.tolist())}"
            + (f" ({fit.headline.why})" if estimated else "")
        )
        lines += _polynomials(m.model.parameters)
        lines += [f"  {_verdict(v)}" for v in m.verdicts if v.level != "good"]
        lines.append(f"  verdict: {m.level}")
    lines += [f"data: {_verdict(v)}" for v in result.verdicts]
    lines += [f"note: {n}" for n in result.notes]
    return "\n".join(lines)


def _verdict(v: Verdict) -> str:
    return f"{v.level}: {v.finding}" + (f"; {v.advice}" if v.advice else "")


def _polynomials(p: ModelParameters | None) -> list[str]:
    """A model's polynomials, one line each (per output, and input, for several)."""
    from elab.ident import parameters as kinds

    def line(name: str, coefficients: Array, where: str = "") -> str:
        return f"  {name}(q){where} = " + " ".join(f"{c:+.4f}" for c in coefficients.tolist())

    match p:
        case kinds.ArxParameters():
            return [line("A", p.A), line("B", p.B)]
        case kinds.ArmaxParameters():
            return [line("A", p.A), line("B", p.B), line("C", p.C)]
        case kinds.OeParameters():
            return [line("B", p.B), line("F", p.F)]
        case kinds.MimoArxParameters():
            return [line("A", a, f" [y{i + 1}]") for i, a in enumerate(p.A)] + [
                line("B", b, f" [y{i + 1}, u{j + 1}]")
                for i, row in enumerate(p.B)
                for j, b in enumerate(row)
            ]
        case kinds.N4sidParameters() | None:
            return []
        case kinds.LinkParameters():
            ratios = ("a", "b", "c", "g", "f", "beta", "beta_l")
            return [
                "  "
                + ", ".join(f"{k} = {getattr(p, k):.5g} ± {p.std[k]:.2g}" for k in ratios)
                + " (a = K_s/J_eq, b = K_s/J_l, c = B_eq/J_eq, g = k_u/J_eq, f = tau_c/J_eq, "
                "beta = B_l/J_eq, beta_l = B_l/J_l)",
                f"  dead zone {p.u_dead:.3g} V, gauge gain {p.sigma:.4g} of its calibration; "
                f"servo fitted on {p.moving_samples} of {p.samples} samples",
            ]
        case _:
            assert_never(p)


def _pct(values: list[float | None]) -> str:
    return ", ".join(
        "undefined" if v is None or not math.isfinite(v) else f"{v:.2f} %" for v in values
    )
