"""``elab check | template``: a controller file's report on a plant's model, and a plant's
controller template in every format."""

from __future__ import annotations

import argparse
from pathlib import Path

from elab.cli.arguments import read_file
from elab.cli.formatting import complex_list, finite_or_none, json_text
from elab.errors import InvalidInput
from elab.plants import get_plant


def cmd_check(args: argparse.Namespace) -> str:
    from elab import controllers
    from elab.engines import coded
    from elab.engines.settings import CodeSettings

    plant = get_plant(args.plant)
    ctrl = read_file(Path(args.file), plant)
    report = coded.report(plant, ctrl.law, CodeSettings(deadline=args.deadline))
    if args.json:
        return json_text(
            {
                "plant": plant.id,
                "controller": controllers.law_fields(ctrl.law),
                "name": ctrl.name,
                "stable": report.stable,
                "closed_loop_poles": complex_list(report.poles),
                "gain_margin_db": finite_or_none(report.gain_margin_db)
                if report.gain_margin_db is not None
                else None,
                "phase_margin_deg": finite_or_none(report.phase_margin_deg)
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
