"""``elab simulate``: a run on a plant's model, its CSV written and summarised; a Python
controller runs in the same sandbox as on the server."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from elab.cli.arguments import parse_law, parse_quantity
from elab.laws import is_code
from elab.plants import Plant, get_plant

# elab.sim brings python-control, scipy.signal and numba: imported when a run is made
if TYPE_CHECKING:
    from elab.sim import RunSpec


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
    res = _simulate_code(spec, args) if is_code(law) else simulate(spec)
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
    from elab.engines.settings import CodeSettings
    from elab.sim.result import Samples
    from elab.sim.spec import compile_run

    run = compile_run(spec)
    out = coded.run_through(run, CodeSettings(deadline=args.deadline))
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
