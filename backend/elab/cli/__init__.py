"""``elab``: the lab on the command line, calling the same functions as the server.

Errors in the input print ``error: <field>: got ...; allowed: ...`` and exit 2.

This module holds the argument parser and the dispatch; each command runs in the module
of its group, imported only when it runs: :mod:`~elab.cli.plants` (plants, analyze,
design), :mod:`~elab.cli.simulate`, :mod:`~elab.cli.identify`,
:mod:`~elab.cli.controller_files` (check, template), :mod:`~elab.cli.server` (serve,
instructor) and :mod:`~elab.cli.rig` (rig-emulator, rig-estop). :mod:`~elab.cli.arguments` reads
the commands' values and :mod:`~elab.cli.formatting` prints their numbers.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable, Sequence
from typing import Any

from elab.cli.identify import ANALYSES
from elab.errors import ElabError
from elab.plants import PLANTS

# Each command imports what it needs: elab.design and elab.sim bring python-control,
# scipy.signal and numba (over a second of imports), which `elab identify` does not need.
# A subcommand names the function that runs it as "module:function" (its `run`).


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="elab", description="E-Lab on the command line")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("plants", help="list the plants")
    p.add_argument("--json", action="store_true")
    p.set_defaults(run="elab.cli.plants:cmd_plants")
    p = sub.add_parser("analyze", help="eigenvalues, stability, controllability, TFs")
    p.add_argument("plant")
    p.add_argument("--json", action="store_true")
    p.set_defaults(run="elab.cli.plants:cmd_analyze")
    p = sub.add_parser("design", help="state-feedback design: lqr or place")
    p.add_argument("method", choices=["lqr", "place"])
    p.add_argument("plant")
    p.add_argument("--Q", help="diagonal of Q, comma-separated")
    p.add_argument("--R", default="1", help="R (scalar)")
    p.add_argument("--poles", help="closed-loop poles, comma-separated, e.g. -5,-6+2j,-6-2j")
    p.add_argument("--json", action="store_true")
    p.set_defaults(run="elab.cli.plants:cmd_design")
    _add_simulate(sub)
    _add_identify(sub)
    p = sub.add_parser("serve", help="run the lab server (REST + websocket stream)")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=8000)
    p.add_argument("--data", help="data directory (default: $ELAB_DATA or ./data)")
    p.set_defaults(run="elab.cli.server:cmd_serve")
    p = sub.add_parser(
        "engine",
        help="a simulation engine of its own on the broker ($ELAB_REDIS_URL): steps the runs "
        "the lab's web servers send it, records them in the store",
    )
    p.add_argument(
        "--name",
        help="its id, one per engine on the store (default: sim-<host name>)",
    )
    p.add_argument("--data", help="data directory (default: $ELAB_DATA or ./data)")
    p.set_defaults(run="elab.cli.server:cmd_engine")
    p = sub.add_parser(
        "migrate", help="bring the store ($ELAB_DATABASE_URL or the data file) to this schema"
    )
    p.add_argument("--data", help="data directory (default: $ELAB_DATA or ./data)")
    p.add_argument(
        "--from",
        dest="source",
        metavar="FILE",
        help="then copy an embedded lab's records from this elab.sqlite3 (into an empty store)",
    )
    p.set_defaults(run="elab.cli.server:cmd_migrate")
    p = sub.add_parser(
        "check", help="read a controller file and print its report on a plant's model"
    )
    p.add_argument("file", help="a .toml, .json, .mat, .npz or .py controller (elab template)")
    p.add_argument("--plant", required=True, choices=list(PLANTS))
    p.add_argument("--json", action="store_true")
    p.add_argument(
        "--deadline", type=float, default=0.5e-3, help="s a Python controller's step may take"
    )
    p.set_defaults(run="elab.cli.controller_files:cmd_check")
    p = sub.add_parser("template", help="write a plant's controller template")
    p.add_argument("plant", choices=list(PLANTS))
    p.add_argument("--format", default="toml", choices=["toml", "json", "mat", "npz", "py"])
    p.add_argument("-o", "--output", help="file to write (default: standard output, text only)")
    p.set_defaults(run="elab.cli.controller_files:cmd_template")
    p = sub.add_parser(
        "instructor",
        help="print an ELAB_INSTRUCTORS line for an instructor account (asks the password)",
    )
    p.add_argument("name", help="the account name (letters, digits, . _ -)")
    p.add_argument(
        "--password-stdin", action="store_true", help="read the password from standard input"
    )
    p.set_defaults(run="elab.cli.server:cmd_instructor")
    p = sub.add_parser("rig-emulator", help="run an emulated flexible-link rig (byte protocol)")
    p.add_argument("--port", type=int, required=True, help="TCP port (0: any free one)")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--rig-seed", type=int, default=0, help="which rig: its hidden parameters")
    p.add_argument(
        "--watchdog-samples",
        type=int,
        default=5,
        help="samples the host may leave unanswered before the motor is cut",
    )
    p.add_argument(
        "--realtime",
        type=int,
        default=0,
        help="SCHED_FIFO priority of its clock, as a board's own (0: an ordinary process)",
    )
    p.add_argument(
        "--exit-with-parent",
        action="store_true",
        help="stop when the process that started it ends (as the server starts it)",
    )
    p.set_defaults(run="elab.cli.rig:cmd_rig_emulator")
    p = sub.add_parser(
        "rig-estop",
        help="emergency stop of the lab's rig: 0 V now, straight to the rig engine "
        "(works while the web server is stopped or busy)",
    )
    p.add_argument(
        "--data", help="the lab's data directory (default: ELAB_DATA, else ./data), as serve's"
    )
    p.add_argument("--who", default="an operator (elab rig-estop)", help="recorded as who")
    p.set_defaults(run="elab.cli.rig:cmd_rig_estop")
    return parser


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
    p.set_defaults(run="elab.cli.simulate:cmd_simulate")


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
    p.add_argument(
        "--reference",
        help="closed-loop data: the reference column(s); the estimation part's input is "
        "replaced by its part the reference explains (two-stage method, "
        "docs/identification.md); validation reads the measured input",
    )
    p.add_argument("--taps", type=int, default=40, help="FIR taps of --reference's first stage")
    p.add_argument(
        "--indirect",
        metavar="NUM/DEN",
        help="closed-loop data under a known controller u = w − C(q) y: C's coefficients "
        "of q⁻¹, e.g. 0.6/1 or 0.5,0.2/1,-0.3 (indirect method, docs/identification.md)",
    )
    p.add_argument("--horizon", type=int, help="subspace block rows")
    p.add_argument(
        "--decimate",
        type=int,
        default=1,
        help="keep every n-th sample after an anti-aliasing filter (default 1: all)",
    )
    p.add_argument("--sine", type=float, help="sine analysis at this frequency (Hz)")
    p.add_argument(
        "--analyses",
        help="non-parametric analyses to run, comma-separated: "
        + ", ".join(ANALYSES)
        + ", all or none (default: all when no --model, --search or --sine is given, "
        "else none)",
    )
    p.add_argument("--json", action="store_true", help="every result as JSON")
    p.set_defaults(run="elab.cli.identify:cmd_identify")


def command(run: str) -> Callable[[argparse.Namespace], str]:
    """The function a subcommand's ``run`` (``"module:function"``) names, its module
    imported now."""
    module, _, name = run.partition(":")
    func: Callable[[argparse.Namespace], str] = getattr(importlib.import_module(module), name)
    return func


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    func = command(args.run)
    try:
        print(func(args))
    except ElabError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0
