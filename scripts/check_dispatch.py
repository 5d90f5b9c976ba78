"""Every union is dispatched exhaustively: adding a member makes mypy name each place
that must learn it (issue 30).

For each union below, a scratch copy of ``backend/elab`` gets one new member (a control
law, a controller model of the wire, a websocket client message, an engine command or
event, an identified model's parameters); mypy then has to fail exactly at the union's
dispatch sites (their ``assert_never``), and nowhere else. A site that dispatches with
an ``isinstance`` chain and a silent fallback would not be named: this check fails then,
and also when a site is named that is not listed here.

Run by ``make typecheck`` (about 30 s: mypy on six scratch copies).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Union:
    name: str
    module: str  # where the union is declared (relative to backend/elab)
    old: str  # its declaration, as it is
    new: str  # a new member's class, then the declaration with it
    sites: frozenset[str]  # the modules that dispatch over it


UNIONS = (
    Union(
        "control laws",
        "laws.py",
        "ControlLaw = StateFeedback | PID | LTIController | OpenLoop | CodeController",
        "@dataclass(frozen=True)\nclass Dummy:\n    gain: float = 1.0\n\n\n"
        "ControlLaw = StateFeedback | PID | LTIController | OpenLoop | CodeController | Dummy",
        frozenset(
            {
                "api/convert.py",
                "design/realise.py",
                "controllers/templates.py",
                "sim/controllers.py",
                "laws.py",  # its questions: is_code, has_feedback, own_sample_time
            }
        ),
    ),
    Union(
        "controller models (the wire)",
        "api/schemas/laws.py",
        "Controller = Annotated[\n    PredefinedController",
        'class DummyController(Model):\n    kind: Literal["dummy"]\n\n\n'
        "Controller = Annotated[\n    DummyController\n    | PredefinedController",
        frozenset({"api/convert.py"}),
    ),
    Union(
        "websocket client messages",
        "api/schemas/stream.py",
        "ClientMessage = Annotated[\n    SetParams",
        'class Dummy(Model):\n    type: Literal["dummy"]\n\n\n'
        "ClientMessage = Annotated[\n    Dummy | SetParams",
        frozenset({"api/stream.py"}),
    ),
    Union(
        "engine commands",
        "engines/wire.py",
        "Command = Add | Control | Replace | Follow | Close",
        "@dataclass(frozen=True)\nclass Dummy:\n    id: int\n\n\n"
        "Command = Add | Control | Replace | Follow | Close | Dummy",
        frozenset({"engines/wire.py", "engines/child.py"}),
    ),
    Union(
        "engine events",
        "engines/wire.py",
        "Event = (\n    Ready",
        "@dataclass(frozen=True)\nclass Dummy:\n    id: int\n\n\nEvent = (\n    Dummy | Ready",
        # handed on in one place (wire.deliver) for both links, the socket and the broker
        frozenset({"engines/wire.py"}),
    ),
    Union(
        "identified model kinds (their parameters)",
        "ident/parameters.py",
        "ModelParameters = (\n    ArxParameters",
        "@dataclass(frozen=True)\nclass Dummy:\n    n: int\n\n\n"
        "ModelParameters = (\n    Dummy | ArxParameters",
        frozenset({"ident/models.py", "ident/assess.py", "api/identjson.py", "cli/identify.py"}),
    ),
    Union(
        "rig queue operations",
        "rig_queue/ops.py",
        "QueueOp = (\n    Join",
        "@dataclass(frozen=True)\nclass Dummy:\n    n: int\n\n\nQueueOp = (\n    Dummy\n    | Join",
        frozenset({"rig_queue/rules.py"}),
    ),
)


def named(union: Union, scratch: Path) -> set[str]:
    """The modules mypy fails in once ``union`` has a new member."""
    src = scratch / "elab"
    shutil.rmtree(src, ignore_errors=True)
    shutil.copytree(ROOT / "backend" / "elab", src, ignore=shutil.ignore_patterns("static"))
    path = src / union.module
    text = path.read_text()
    if union.old not in text:
        raise SystemExit(f"{union.module} no longer declares {union.name} as {union.old!r}")
    path.write_text(text.replace(union.old, union.new, 1))
    # a fresh mtime: mypy's cache (shared by the copies) trusts a file whose mtime and size
    # it has seen, and two unions' edits of one module may be the same size within a second
    later = time.time_ns() + 10**9 * (UNIONS.index(union) + 1)
    os.utime(path, ns=(later, later))
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--config-file",
            str(ROOT / "pyproject.toml"),
            "--cache-dir",
            str(scratch / "cache"),
            str(src),
        ],
        cwd=scratch,
        capture_output=True,
        text=True,
    ).stdout
    files = set(re.findall(r"^elab/(\S+?\.py):\d+: error", out, re.M))
    if not files and "Success" not in out:
        raise SystemExit(f"mypy did not run on the copy for {union.name}:\n{out}")
    return files


def main() -> int:
    failed = False
    with tempfile.TemporaryDirectory() as tmp:
        for union in UNIONS:
            got = named(union, Path(tmp))
            if got != union.sites:
                failed = True
                print(
                    f"{union.name}: a new member should fail mypy at {sorted(union.sites)}; "
                    f"it fails at {sorted(got)}"
                    + (
                        f" (silently accepted at {sorted(union.sites - got)}: dispatch there "
                        "with match … case _: assert_never)"
                        if union.sites - got
                        else ""
                    )
                )
            else:
                print(f"{union.name}: a new member is named at {', '.join(sorted(got))}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
