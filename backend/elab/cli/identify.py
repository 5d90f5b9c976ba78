"""``elab identify``: models and analyses from a data file, as the server's identification
gives them (``--json``: the API's answer). Imports only the identification it runs."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from elab.errors import InvalidInput

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

    def dataset(name: str, field: str) -> Any:
        path = Path(name)
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise InvalidInput(field, name, f"a readable file ({exc.strerror})") from None
        table = read_table(raw, "json" if path.suffix.lower() == ".json" else "csv")
        return table.dataset(_names(args.input), _names(args.output), args.Ts)

    data = dataset(args.data, "data")
    validation = None if args.validation is None else dataset(args.validation, "validation")
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
    )
    result = wf.run(data, plan, validation=validation)
    if args.json:  # the API's answer, validated against the same wire model
        from elab.api.convert import ident_json

        return ident_json(result)
    return _identify_text(data, result)


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


def _identify_text(data: Any, result: Any) -> str:
    d = result.data
    lines = [
        f"data: {d['N']} samples at Ts = {d['Ts']:g} s, inputs {', '.join(d['input_names'])}"
        f", outputs {', '.join(d['output_names'])}; estimation {d['estimation']} samples, "
        f"validation {d['N'] - d['estimation']}; detrend {d['trend']}"
    ]
    a = result.analyses
    if "correlation" in a:
        delay = a["correlation"]["delay"]
        lines.append(
            "correlation analysis: "
            + (
                f"delay {delay} samples"
                if delay is not None
                else "no delay found (no impulse-response coefficient is significant)"
            )
        )
    if "spectral" in a:
        sp = a["spectral"]
        peak = int(np.argmax(sp["magnitude"]))
        lines.append(
            f"spectral analysis (lag window {sp['window']}): |G| = {sp['magnitude'][0]:.4g} at "
            f"{sp['omega'][0]:.4g} rad/s, largest {sp['magnitude'][peak]:.4g} at "
            f"{sp['omega'][peak]:.4g} rad/s (--json: all {len(sp['omega'])} frequencies)"
        )
    for s in ([a["arx_search"]] if "arx_search" in a else []) + a.get("arx_search_outputs", []):
        best = min(s["rows"], key=lambda r: r[3])
        lines.append(
            f"ARX search{' for ' + s['output'] if 'output' in s else ''} over "
            f"{len(s['rows'])} structures: best [na nb nk] = {s['best']} (validation loss "
            f"{best[3]:.6g}); AIC {s['aic']}, MDL {s['mdl']}"
        )
    if "n4sid_orders" in a:
        o = a["n4sid_orders"]
        sv = ", ".join(f"{v:.4g}" for v in o["singular_values"][:8])
        lines.append(
            f"subspace (horizon {o['horizon']}): singular values {sv}, …; order {o['best']}: "
            f"{o['reason']}"
        )
    if "sine" in a:
        sn = a["sine"]
        lines.append(
            f"sine analysis at {sn['frequency_hz']:g} Hz: |G| = {sn['magnitude']:.4g},"
            f" phase {sn['phase_deg']:.1f} deg"
        )
    m_nu = len(result.data["input_names"])
    for m in result.models:
        fit = m["fit"]
        lines.append(
            f"{m['name']}: validation fit {_pct(fit['headline'])} (simulation, "
            f"{'estimated' if fit['headline_x0'] == 'estimated' else 'zero'} initial state), "
            f"{_pct(fit['validation_one_step'])} (one step)"
        )
        other = (
            "validation_simulation"
            if fit["headline_x0"] == "estimated"
            else "validation_simulation_x0"
        )
        lines.append(
            f"  from the {'zero' if fit['headline_x0'] == 'estimated' else 'estimated'} "
            f"initial state: {_pct(fit[other])}"
            + (f" ({fit['headline_why']})" if fit["headline_x0"] == "estimated" else "")
        )
        p = m["parameters"]
        for key in ("A", "B", "C", "F"):
            rows = p.get(key)
            if not rows:
                continue
            if not isinstance(rows[0], list):  # one output, one input
                lines.append(f"  {key}(q) = " + " ".join(f"{c:+.4f}" for c in rows))
                continue
            for i, row in enumerate(rows):  # MIMO ARX: A per output, B per output and input
                where = f"y{i + 1}" if key == "A" else f"y{i // m_nu + 1}, u{i % m_nu + 1}"
                lines.append(f"  {key}(q) [{where}] = " + " ".join(f"{c:+.4f}" for c in row))
    lines += [f"note: {n}" for n in result.notes]
    return "\n".join(lines)


def _pct(values: list[float | None]) -> str:
    return ", ".join(
        "undefined" if v is None or not math.isfinite(v) else f"{v:.2f} %" for v in values
    )
