"""``elab``: the lab on the command line, calling the same functions as the server.

Errors in the input print ``error: <field>: got ...; allowed: ...`` and exit 2.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, assert_never

import numpy as np

from elab.errors import ElabError, InvalidInput
from elab.laws import PID, CodeController, ControlLaw, OpenLoop, StateFeedback
from elab.plants import PLANTS, Plant, get_plant

# Each command imports what it needs: elab.design and elab.sim bring python-control,
# scipy.signal and numba (over a second of imports), which `elab identify` does not need.
if TYPE_CHECKING:
    from elab.ident.parameters import Array, ModelParameters
    from elab.ident.results import Result
    from elab.sim import RunSpec

ANALYSES = ("correlation", "spectral")  # elab identify --analyses
UNITS = {"deg": math.pi / 180, "rad": 1.0, "mm": 1e-3, "m": 1.0, "V": 1.0, "s": 1.0, "Hz": 1.0}


def parse_quantity(text: str, field: str = "value") -> float:
    """``"30deg"`` → 0.5236 (SI); a plain number is taken as SI."""
    for suffix, factor in sorted(UNITS.items(), key=lambda kv: -len(kv[0])):
        if text.endswith(suffix):
            return _number(text[: -len(suffix)], field, text) * factor
    return _number(text, field, text)


def _number(text: str, field: str, original: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise InvalidInput(
            field, original, "a number, optionally with a unit: " + ", ".join(UNITS)
        ) from None
    if not math.isfinite(x):
        raise InvalidInput(field, original, "a finite number")
    return x


def parse_vector(text: str, field: str) -> tuple[float, ...]:
    """``"400,1e4,3,2"`` → a tuple of floats (complex allowed via ``complex_vector``)."""
    return tuple(parse_quantity(p.strip(), field) for p in text.split(",") if p.strip())


def parse_complex_vector(text: str, field: str) -> tuple[complex, ...]:
    try:
        values = tuple(complex(p.strip().replace("i", "j")) for p in text.split(","))
    except ValueError:
        raise InvalidInput(field, text, "comma-separated numbers such as -5,-6+2j,-6-2j") from None
    return values


def read_file(path: Path, plant: Plant) -> Any:
    """A controller file (any format of ``elab template``), read for ``plant``: its
    :class:`elab.controllers.Controller` (a Python one named after the file)."""
    from elab import controllers

    fmt = controllers.format_of(path.name)
    try:
        with path.open("rb") as f:
            data = f.read(controllers.files.MAX_BYTES + 1)
    except OSError as exc:
        raise InvalidInput("file", str(path), f"a readable file ({exc.strerror})") from None
    ctrl = controllers.read_controller(data, fmt, plant)
    if isinstance(ctrl.law, CodeController):
        ctrl = replace(ctrl, law=CodeController(ctrl.law.source, path.name))
    return ctrl


def parse_law(text: str, plant: Plant, estimate: str) -> ControlLaw:
    """``predefined`` | ``open`` | ``K:k1,k2,...`` | ``pid:Kp,Ki,Kd`` | ``lqr:Q1,..,Qn;R``
    | a controller file (``my.py``, ``my.toml``, ...)."""
    if text.rsplit(".", 1)[-1].lower() in ("toml", "json", "mat", "npz", "py"):
        return read_file(Path(text), plant).law  # type: ignore[no-any-return]
    kind, _, arg = text.partition(":")
    if kind == "predefined":
        return plant.predefined
    if kind == "open":
        return OpenLoop()
    if kind == "K":
        return StateFeedback(parse_vector(arg, "controller.K"), estimate)  # type: ignore[arg-type]
    if kind == "pid":
        gains = parse_vector(arg, "controller.pid")
        if not 1 <= len(gains) <= 3:
            raise InvalidInput("controller.pid", arg, "1 to 3 gains: Kp[,Ki[,Kd]]")
        return PID(*gains)
    if kind == "lqr":
        from elab import design

        q, _, r = arg.partition(";")
        K = design.design_lqr(plant, parse_vector(q, "Q"), parse_quantity(r or "1", "R")).K
        return StateFeedback(tuple(float(k) for k in np.ravel(K)), estimate)  # type: ignore[arg-type]
    raise InvalidInput(
        "controller",
        text,
        "predefined, open, K:k1,..,kn, pid:Kp,Ki,Kd, lqr:q1,..,qn;R or a controller file "
        "(.toml, .json, .mat, .npz, .py)",
    )


def cmd_plants(args: argparse.Namespace) -> str:
    if args.json:
        return _json(
            [
                {"id": p.id, "name": p.name, "summary": p.summary, "modes": p.modes}
                for p in PLANTS.values()
            ]
        )
    return "\n".join(f"{p.id:18} {p.name:26} {p.summary}" for p in PLANTS.values())


def _closed_loop_figures(plant: Plant) -> tuple[Any, Any, Any]:
    """Stability, step metrics (10 % of the default reference) and margins of the
    predefined loop, continuous and unsaturated."""
    from elab import design

    cl = design.closed_loop(plant, plant.predefined)
    stab = design.stability(cl.A)
    step = design.step_response(
        cl, T=design.default_horizon(stab.eigenvalues), n=20001, u_output=-1
    )
    info = design.step_info(step.t, step.y[plant.reference_output])
    return stab, info, design.margins(design.loop_transfer(plant, plant.predefined))


def cmd_analyze(args: argparse.Namespace) -> str:
    from elab import design
    from elab.runs.export import describe

    plant = get_plant(args.plant)
    a = design.analyze(plant)
    cl_stab, info, m = _closed_loop_figures(plant)
    if args.json:
        return _json(
            {
                "plant": plant.id,
                "eigenvalues": _complex_list(a.stability.eigenvalues),
                "stability": {"verdict": a.stability.verdict, "reason": a.stability.reason},
                "controllability": _rank(a.controllability),
                "observability": _rank(a.observability),
                "transfer_functions": [
                    {
                        "output": tf.output,
                        "input": tf.input,
                        "num": tf.num.tolist(),
                        "den": tf.den.tolist(),
                    }
                    for tf in a.transfer_functions
                ],
                "predefined": {
                    "law": describe(plant.predefined),
                    "design": plant.predefined_design,
                    "closed_loop_poles": _complex_list(cl_stab.eigenvalues),
                    "verdict": cl_stab.verdict,
                    "unit_step": {k: _finite_or_none(v) for k, v in vars(info).items()},
                    "margins": {k: _finite_or_none(v) for k, v in vars(m).items()},
                },
            }
        )
    lines = [
        f"{plant.name} ({plant.id})",
        "",
        "eigenvalues: " + ", ".join(_c(z) for z in a.stability.eigenvalues),
        f"open loop: {a.stability.verdict} — {a.stability.reason}",
        _rank_text("controllability", a.controllability),
        _rank_text("observability", a.observability),
        "",
        "transfer functions:",
    ]
    lines += [f"  {tf.output}/{tf.input} = {tf.text()}" for tf in a.transfer_functions]
    lines += [
        "",
        f"predefined controller: {describe(plant.predefined)}",
        f"  {plant.predefined_design}",
        "  closed-loop poles: " + ", ".join(_c(z) for z in cl_stab.eigenvalues),
        f"  closed loop: {cl_stab.verdict}",
        f"  unit step (linear): rise {info.rise_time:.3g} s, settling (2 %) "
        f"{info.settling_time:.3g} s, overshoot {info.overshoot:.3g} %, "
        f"steady-state error {info.steady_state_error:.2g}",
        f"  margins (loop broken at u): {_margins_text(m)}",
    ]
    return "\n".join(lines)


def _margins_text(m: Any) -> str:
    if not math.isfinite(m.gain_margin_db):
        gain = "gain ∞ (no phase crossover)"
    elif m.gain_margin_db < 0:
        gain = (
            f"gain {m.gain_margin_db:.3g} dB at {m.phase_crossover:.4g} rad/s (a gain "
            "decrease that much destabilises: the open loop is unstable)"
        )
    else:
        gain = f"gain {m.gain_margin_db:.3g} dB at {m.phase_crossover:.4g} rad/s"
    if not math.isfinite(m.phase_margin_deg):
        return f"{gain}, phase ∞ (no gain crossover)"
    return f"{gain}, phase {m.phase_margin_deg:.3g}° at {m.gain_crossover:.4g} rad/s"


def cmd_design(args: argparse.Namespace) -> str:
    from elab import design

    plant = get_plant(args.plant)
    if args.method == "lqr":
        if args.Q is None:
            raise InvalidInput("Q", None, f"{plant.nx} diagonal weights, e.g. --Q 1,1,...")
        res = design.design_lqr(plant, parse_vector(args.Q, "Q"), parse_quantity(args.R, "R"))
        K, poles = np.ravel(res.K), res.poles
    else:
        if args.poles is None:
            raise InvalidInput("poles", None, f"{plant.nx} poles, e.g. --poles -5,-6,-7+2j,-7-2j")
        pl = design.design_place(plant, parse_complex_vector(args.poles, "poles"))
        K, poles = np.ravel(pl.K), pl.poles
    if args.json:
        return _json(
            {
                "plant": plant.id,
                "method": args.method,
                "K": K.tolist(),
                "closed_loop_poles": _complex_list(poles),
                "convention": "u = K (x_ref - x)",
            }
        )
    return "\n".join(
        [
            f"K = [{' '.join(f'{k:.6g}' for k in K)}]   (u = K (x_ref − x))",
            "closed-loop poles: " + ", ".join(_c(z) for z in poles),
        ]
    )


def cmd_simulate(args: argparse.Namespace) -> str:
    from elab.runs.export import describe, to_csv
    from elab.sim import RunSpec, make_signal, simulate

    plant = get_plant(args.plant)
    law = parse_law(args.controller, plant, args.estimate)
    params: dict[str, Any] = {"amplitude": parse_quantity(args.amplitude, "signal.amplitude")}
    for name in ("period", "frequency", "offset", "band"):
        if getattr(args, name) is not None:
            params[name] = parse_quantity(getattr(args, name), f"signal.{name}")
    if args.order is not None:
        params["order"] = args.order
    if args.signal == "square" and "period" not in params:
        params["period"] = plant.signal.period or 4.0
    spec = RunSpec(
        plant,
        law,
        make_signal(args.signal, **params),
        duration=args.duration,
        Ts=args.Ts,
        saturate=False if args.no_saturation else None,
        noise_seed=args.noise_seed,
        quantize=args.quantize,
    )
    res = simulate(spec) if not isinstance(law, CodeController) else _simulate_code(spec, args)
    header = {
        "plant": f"{plant.id} ({plant.name})",
        "controller": describe(law),
        "signal": describe(spec.reference),
        "generator": "elab simulate",
    }
    if args.out:
        Path(args.out).write_text(to_csv(res, header), encoding="utf-8")
    return _simulate_summary(plant, spec, res, args.out)


def _simulate_code(spec: RunSpec, args: argparse.Namespace) -> Any:
    """A run of a Python controller, in its sandbox, as the server steps it."""
    from elab.engines import coded
    from elab.sim.result import Samples
    from elab.sim.spec import compile_run

    run = compile_run(spec)
    out = coded.run_through(run, coded.CodeSettings(deadline=args.deadline))
    p, rows = spec.plant, out.rows
    t = out.times
    print(
        f"controller compute time per step: median {t['median_us']:.3g} µs, p99 "
        f"{t['p99_us']:.3g} µs; {t['misses']} late of {t['steps']}",
        file=sys.stderr,
    )
    if out.failed is not None and not out.failed.startswith("diverged"):
        print(f"FAILED: {out.failed}", file=sys.stderr)
    return Samples(
        p,
        run.Ts,
        0,
        rows[:, 0].copy(),
        rows[:, 1].copy(),
        rows[:, 2 : 2 + p.ny].copy(),
        rows[:, 2 + p.ny :].copy(),
    )


def _simulate_summary(plant: Plant, spec: RunSpec, res: Any, out: str | None) -> str:
    i = plant.reference_output
    ref = plant.outputs[i]
    y = res.y[:, i]
    lines = [
        f"{res.n} samples at Ts = {res.Ts:g} s, {res.n * res.Ts:g} s simulated",
        f"{ref.name}: min {y.min():.4g}, max {y.max():.4g} {ref.unit};  "
        f"u: min {res.u.min():.4g}, max {res.u.max():.4g} V",
    ]
    expected = round(spec.duration / res.Ts)
    if res.n < expected:
        lines.append(f"DIVERGED at t = {res.n * res.Ts:.4g} s: the closed loop is unstable")
    if out:
        lines.append(f"wrote {out}")
    return "\n".join(lines)


def _rank(r: Any) -> dict[str, Any]:
    return {
        "rank": r.rank,
        "full": r.full,
        "condition_number": r.condition_number,
        "singular_values": r.singular_values.tolist(),
    }


def _rank_text(name: str, r: Any) -> str:
    n = min(r.matrix.shape)
    word = "full rank" if r.full else "rank deficient"
    return f"{name}: rank {r.rank} of {n} ({word}, condition number {r.condition_number:.3g})"


def _c(z: complex) -> str:
    z = complex(z)
    if abs(z.imag) < 1e-12:
        return f"{z.real:.6g}"
    return f"{z.real:.6g}{z.imag:+.6g}j"


def _complex_list(zs: Any) -> list[list[float]]:
    return [[float(complex(z).real), float(complex(z).imag)] for z in zs]


def _finite_or_none(x: float) -> float | None:
    """JSON has no NaN or infinity: undefined figures become null."""
    return float(x) if math.isfinite(x) else None


def _json(obj: Any) -> str:
    return json.dumps(obj, indent=2)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="elab", description="E-Lab on the command line")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("plants", help="list the plants")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_plants)
    p = sub.add_parser("analyze", help="eigenvalues, stability, controllability, TFs")
    p.add_argument("plant")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_analyze)
    p = sub.add_parser("design", help="state-feedback design: lqr or place")
    p.add_argument("method", choices=["lqr", "place"])
    p.add_argument("plant")
    p.add_argument("--Q", help="diagonal of Q, comma-separated")
    p.add_argument("--R", default="1", help="R (scalar)")
    p.add_argument("--poles", help="closed-loop poles, comma-separated, e.g. -5,-6+2j,-6-2j")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_design)
    _add_simulate(sub)
    _add_identify(sub)
    p = sub.add_parser("serve", help="run the lab server (REST + websocket stream)")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=8000)
    p.add_argument("--data", help="data directory (default: $ELAB_DATA or ./data)")
    p.set_defaults(func=cmd_serve)
    p = sub.add_parser(
        "check", help="read a controller file and print its report on a plant's model"
    )
    p.add_argument("file", help="a .toml, .json, .mat, .npz or .py controller (elab template)")
    p.add_argument("--plant", required=True, choices=list(PLANTS))
    p.add_argument("--json", action="store_true")
    p.add_argument(
        "--deadline", type=float, default=0.5e-3, help="s a Python controller's step may take"
    )
    p.set_defaults(func=cmd_check)
    p = sub.add_parser("template", help="write a plant's controller template")
    p.add_argument("plant", choices=list(PLANTS))
    p.add_argument("--format", default="toml", choices=["toml", "json", "mat", "npz", "py"])
    p.add_argument("-o", "--output", help="file to write (default: standard output, text only)")
    p.set_defaults(func=cmd_template)
    p = sub.add_parser(
        "instructor",
        help="print an ELAB_INSTRUCTORS line for an instructor account (asks the password)",
    )
    p.add_argument("name", help="the account name (letters, digits, . _ -)")
    p.add_argument(
        "--password-stdin", action="store_true", help="read the password from standard input"
    )
    p.set_defaults(func=cmd_instructor)
    return parser


def cmd_check(args: argparse.Namespace) -> str:
    from elab import controllers
    from elab.engines import coded

    plant = get_plant(args.plant)
    ctrl = read_file(Path(args.file), plant)
    report = coded.report(plant, ctrl.law, coded.CodeSettings(deadline=args.deadline))
    if args.json:
        return _json(
            {
                "plant": plant.id,
                "controller": controllers.law_fields(ctrl.law),
                "name": ctrl.name,
                "stable": report.stable,
                "closed_loop_poles": _complex_list(report.poles),
                "gain_margin_db": _finite_or_none(report.gain_margin_db)
                if report.gain_margin_db is not None
                else None,
                "phase_margin_deg": _finite_or_none(report.phase_margin_deg)
                if report.phase_margin_deg is not None
                else None,
                "peak_u": report.peak_u,
                "u_max": report.u_max,
                "rig_ready": report.rig_ready,
                "problems": list(report.problems),
                "warnings": list(report.warnings),
                "compute": report.compute,
                "trial": report.trial,
            }
        )
    return report.text()


def cmd_template(args: argparse.Namespace) -> str:
    from elab.controllers import template

    data = template(get_plant(args.plant), args.format)
    if args.output:
        Path(args.output).write_bytes(data)
        return f"wrote {args.output} ({args.format}, {len(data)} bytes)"
    if args.format in ("mat", "npz"):
        raise InvalidInput("output", None, f"a file to write the binary {args.format} to (-o)")
    return data.decode().rstrip("\n")


def cmd_instructor(args: argparse.Namespace) -> str:
    import getpass

    from elab.api.auth import hash_password, valid_name

    if not valid_name(args.name):
        raise InvalidInput("name", args.name, "1-40 letters, digits, '.', '_' or '-'")
    if args.password_stdin:
        password = sys.stdin.readline().rstrip("\n")
    else:
        password = getpass.getpass(f"password for {args.name}: ")
        if getpass.getpass("again: ") != password:
            raise InvalidInput("password", "…", "the same password twice")
    if len(password) < 8:
        raise InvalidInput("password", "…", "at least 8 characters")
    return f"{args.name}:{hash_password(password)}"


def cmd_serve(args: argparse.Namespace) -> str:
    import os

    import uvicorn

    from elab.api.app import create_app
    from elab.api.settings import Settings
    from elab.runtime import return_memory

    if args.data:
        os.environ["ELAB_DATA"] = args.data
    return_memory()  # before the app allocates: big requests give their memory back
    settings = Settings.from_env()
    if args.host not in ("0.0.0.0", "::", "") and args.host not in settings.hosts:
        settings = replace(settings, hosts=(*settings.hosts, args.host))
    print(f"E-Lab on http://{args.host}:{args.port}  (data: {settings.database})", flush=True)
    # no permessage-deflate: float32 samples hardly compress, and deflating every frame
    # for every watcher cost a third of the server's CPU (docs/benchmarks.md). uvicorn's
    # "auto" loop is uvloop (a dependency): p99 latency 106 -> 60 ms at 300 runs there.
    uvicorn.run(
        create_app(settings),
        host=args.host,
        port=args.port,
        log_level="warning",
        ws_max_size=1 << 20,
        ws_per_message_deflate=False,
        # h11 refuses a head still incomplete past this many bytes, so whether a long one
        # (a 120 KB cookie) was answered depended on how its packets arrived (16 KiB by
        # default): one budget, checked the same way every time
        h11_max_incomplete_event_size=settings.max_head,
        # X-Forwarded-* only from the configured proxies (uvicorn trusts 127.0.0.1 by
        # default: rotating X-Forwarded-For beat the sign-in limit from loopback)
        proxy_headers=bool(settings.trusted_proxies),
        forwarded_allow_ips=list(settings.trusted_proxies) or None,
    )
    return "E-Lab stopped"


def _add_simulate(sub: Any) -> None:
    p = sub.add_parser("simulate", help="simulate a run and write its CSV")
    p.add_argument("plant")
    p.add_argument(
        "--controller",
        default="predefined",
        help="predefined | open | K:k1,..,kn | pid:Kp,Ki,Kd | lqr:q1,..,qn;R | a controller "
        "file (my.toml, my.py: Python runs in the same sandbox as on the server)",
    )
    p.add_argument(
        "--deadline",
        type=float,
        default=0.5e-3,
        help="s a Python controller's step may take before the last u is held",
    )
    p.add_argument(
        "--estimate",
        default="velocity_filters",
        choices=["true_state", "velocity_filters"],
        help="state feedback on true states or on outputs + velocity filters",
    )
    p.add_argument("--signal", default="square", help="step, square, sine, chirp, prbs")
    p.add_argument("--amplitude", default="30deg", help="with unit: 30deg, 0.5rad, 0.2m, 2V")
    p.add_argument("--period", help="square wave period (s)")
    p.add_argument("--frequency", help="sine frequency (Hz)")
    p.add_argument("--offset")
    p.add_argument("--band", help="PRBS band (fraction of Nyquist)")
    p.add_argument("--order", type=int, help="PRBS register length")
    p.add_argument("--duration", type=float, default=10.0, help="s")
    p.add_argument("--Ts", type=float, help="sample time (s); default: the plant's")
    p.add_argument("--noise-seed", type=int, help="add seeded sensor noise")
    p.add_argument("--quantize", action="store_true", help="round outputs to encoder counts")
    p.add_argument("--no-saturation", action="store_true")
    p.add_argument("--out", help="CSV file to write")
    p.set_defaults(func=cmd_simulate)


def _add_identify(sub: Any) -> None:
    p = sub.add_parser("identify", help="identify models from a data file (CSV, JSON, .dat)")
    p.add_argument("data", help="file: an E-Lab CSV/JSON download or numeric columns")
    p.add_argument(
        "--input",
        default="u",
        help="input column(s), comma-separated (unnamed columns are c1, c2, …)",
    )
    p.add_argument("--output", default="y", help="output column(s), comma-separated")
    p.add_argument("--Ts", type=float, help="sample time (s); default: from the file")
    p.add_argument(
        "--model",
        action="append",
        default=[],
        help="arx:na,nb,nk | armax:na,nb,nc,nk | oe:nb,nf,nk | n4sid[:n[,horizon]] (repeatable)",
    )
    p.add_argument(
        "--search",
        action="append",
        default=[],
        help="arx:na1-na2,nb1-nb2,nk1-nk2 | n4sid:n1-n2 (order searches)",
    )
    p.add_argument("--split", type=float, default=0.5, help="estimation share (default 0.5)")
    p.add_argument(
        "--validation",
        help="a separate record to validate on (the same columns); the data file is then "
        "all estimation, and its means detrend both",
    )
    p.add_argument("--detrend", default="mean", choices=["mean", "linear", "none"])
    p.add_argument("--horizon", type=int, help="subspace block rows")
    p.add_argument("--sine", type=float, help="sine analysis at this frequency (Hz)")
    p.add_argument(
        "--analyses",
        help="non-parametric analyses to run, comma-separated: "
        + ", ".join(ANALYSES)
        + ", all or none (default: all when no --model, --search or --sine is given, "
        "else none)",
    )
    p.add_argument("--json", action="store_true", help="every result as JSON")
    p.set_defaults(func=cmd_identify)


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
        from elab.api.identjson import ident_json

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
    lines += [f"note: {n}" for n in result.notes]
    return "\n".join(lines)


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
        case _:
            assert_never(p)


def _pct(values: list[float | None]) -> str:
    return ", ".join(
        "undefined" if v is None or not math.isfinite(v) else f"{v:.2f} %" for v in values
    )


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    func: Callable[[argparse.Namespace], str] = args.func
    try:
        print(func(args))
    except ElabError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
