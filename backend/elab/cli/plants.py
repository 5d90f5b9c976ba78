"""``elab plants | analyze | design``: the plants, their models analysed (eigenvalues,
ranks, transfer functions, the predefined loop) and state feedback designed for them."""

from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np

from elab.cli.arguments import parse_complex_vector, parse_quantity, parse_vector
from elab.cli.formatting import complex_list, complex_text, finite_or_none, json_text
from elab.errors import InvalidInput
from elab.plants import PLANTS, Plant, get_plant


def cmd_plants(args: argparse.Namespace) -> str:
    if args.json:
        return json_text(
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
        return json_text(
            {
                "plant": plant.id,
                "eigenvalues": complex_list(a.stability.eigenvalues),
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
                    "closed_loop_poles": complex_list(cl_stab.eigenvalues),
                    "verdict": cl_stab.verdict,
                    "unit_step": {k: finite_or_none(v) for k, v in vars(info).items()},
                    "margins": {k: finite_or_none(v) for k, v in vars(m).items()},
                },
            }
        )
    lines = [
        f"{plant.name} ({plant.id})",
        "",
        "eigenvalues: " + ", ".join(complex_text(z) for z in a.stability.eigenvalues),
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
        "  closed-loop poles: " + ", ".join(complex_text(z) for z in cl_stab.eigenvalues),
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
        return json_text(
            {
                "plant": plant.id,
                "method": args.method,
                "K": K.tolist(),
                "closed_loop_poles": complex_list(poles),
                "convention": "u = K (x_ref - x)",
            }
        )
    return "\n".join(
        [
            f"K = [{' '.join(f'{k:.6g}' for k in K)}]   (u = K (x_ref − x))",
            "closed-loop poles: " + ", ".join(complex_text(z) for z in poles),
        ]
    )
