"""Controllers offline from the command line: a template in Python, checked by its trial
and simulated in the sandbox with the samples of the class the server steps it with; a
declarative file simulated as the same law given inline; errors that say what is wrong."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from elab.cli import main
from elab.controllers.sandbox import available
from elab.engines.coded import run_through
from elab.engines.settings import CodeSettings
from elab.laws import CodeController
from elab.plants import get_plant
from elab.sim import RunSpec, Square, compile_run

pytestmark = pytest.mark.skipif(available() is not None, reason=str(available()))
FLEX = get_plant("flexible_link")


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def csv_rows(path: Path) -> np.ndarray:
    lines = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    return np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])


def test_a_python_template_checked_and_simulated_as_the_server_steps_it(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    py = tmp_path / "mine.py"
    code, out, _ = run(capsys, "template", "flexible_link", "--format", "py", "-o", str(py))
    assert code == 0 and "class Controller" in py.read_text()
    code, out, _ = run(capsys, "check", str(py), "--plant", "flexible_link", "--json")
    report = json.loads(out)
    assert code == 0 and report["rig_ready"] and report["compute"]["steps"] >= 20_000
    csv = tmp_path / "run.csv"
    code, out, err = run(
        capsys,
        "simulate",
        "flexible_link",
        "--controller",
        str(py),
        "--duration",
        "2",
        "--noise-seed",
        "5",
        "--out",
        str(csv),
    )
    assert (
        code == 0
        and "compute time per step" in err
        and "CodeController(name=mine.py)" in (csv.read_text())
    )
    signal = Square(float(np.radians(30)), float(FLEX.signal.period))
    law = CodeController(py.read_text(), "mine.py")
    spec = RunSpec(FLEX, law, signal, duration=2.0, noise_seed=5)
    rows = run_through(compile_run(spec), CodeSettings()).rows
    got = csv_rows(csv)
    assert got.shape == (2000, 1 + rows.shape[1])
    assert np.array_equal(got[:, 1:], rows)  # CSV numbers are exact (repr)


def test_a_declarative_file_simulates_as_the_law_given_inline(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    toml = tmp_path / "pid.toml"
    toml.write_text('version = 1\nkind = "pid"\nKp = 12\nKi = 0.49\nKd = 0.5\n')
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    common = ("--signal", "step", "--amplitude", "0.2m", "--duration", "3")
    assert (
        run(
            capsys, "simulate", "belt_conveyor", "--controller", str(toml), *common, "--out", str(a)
        )[0]
        == 0
    )
    assert (
        run(
            capsys,
            "simulate",
            "belt_conveyor",
            "--controller",
            "pid:12,0.49,0.5",
            *common,
            "--out",
            str(b),
        )[0]
        == 0
    )
    assert np.array_equal(csv_rows(a), csv_rows(b))


def test_a_controller_file_that_is_not_there_or_broken_says_so(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    code, _, err = run(capsys, "simulate", "flexible_link", "--controller", "nowhere.py")
    assert code == 2 and "nowhere.py" in err and "readable file" in err
    bad = tmp_path / "bad.py"
    bad.write_text("class Controller:\n    def step(self, t, y, r)\n        return 0\n")
    code, _, err = run(capsys, "check", str(bad), "--plant", "flexible_link")
    assert code == 2 and "line 2, column" in err
