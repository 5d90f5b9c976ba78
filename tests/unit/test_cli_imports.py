"""The CLI imports what a command needs: ``elab identify --model n4sid:4`` loads neither
python-control, scipy.signal nor numba (together over a second of imports on the lab's
machine; docs/benchmarks.md). Checked on the import log, which cannot flake as a time can."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DRYER = ROOT / "tests" / "reference" / "ident" / "dryer.dat"
DRYER_ARGS = ("identify", str(DRYER), "--input", "c1", "--output", "c2", "--Ts", "0.08")
HEAVY = frozenset({"control", "scipy.signal", "numba", "matplotlib", "elab.design", "elab.sim"})


def imported(*args: str) -> tuple[set[str], subprocess.CompletedProcess[str]]:
    """The modules ``python -X importtime *args`` imports, and the process."""
    proc = subprocess.run(
        [sys.executable, "-X", "importtime", *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=ROOT,
    )
    names = {
        line.rsplit("|", 1)[1].strip()
        for line in proc.stderr.splitlines()
        if line.startswith("import time:") and line.count("|") == 2
    }
    return names, proc


def test_importing_the_cli_loads_none_of_the_commands_heavy_modules() -> None:
    names, proc = imported("-c", "import elab.cli")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "elab.cli" in names  # the log is read right
    assert not names & HEAVY


def test_a_subspace_model_alone_loads_neither_python_control_nor_scipy_signal() -> None:
    names, proc = imported("-m", "elab.cli", *DRYER_ARGS, "--model", "n4sid:4")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "elab.ident.subspace" in names
    assert not names & HEAVY
    assert "n4sid 4: validation fit" in proc.stdout
    assert "correlation" not in proc.stdout and "spectral" not in proc.stdout


def test_the_analyses_load_scipy_signal_when_asked() -> None:
    """The other side of the check above: the log does show scipy.signal when it is used."""
    names, proc = imported(
        "-m", "elab.cli", *DRYER_ARGS, "--model", "n4sid:4", "--analyses", "correlation"
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "scipy.signal" in names and "control" not in names
    assert "correlation analysis: delay 3 samples" in proc.stdout


#: what the web process must start without (docs/architecture.md, start-up): the design
#: and identification endpoints, the engine and the trial workers import them when used
WEB_HEAVY = frozenset({"control", "scipy.signal", "scipy.stats", "scipy.io", "numba", "matplotlib"})


def test_the_web_process_starts_without_python_control_scipy_signal_or_numba() -> None:
    names, proc = imported("-c", "import elab.api.app")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert {"elab.api.designs", "elab.api.plants", "elab.api.ident"} <= names  # read right
    assert not names & WEB_HEAVY, sorted(names & WEB_HEAVY)


def test_the_web_app_loads_no_scipy_python_control_or_numba() -> None:
    """``elab serve``'s web process serves while the fork server imports the numerical
    stack for the engine and the workers (api/preload.py): the app's module imports none
    of it (scipy alone was 0.25 s of its start-up, through the identification and design
    modules' ``scipy.linalg``)."""
    names, proc = imported("-c", "import elab.api.app")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "elab.api.app" in names and "elab.ident.workflow" in names  # the log is read right
    assert not {n for n in names if n.split(".")[0] in {"scipy", "control", "numba"}}


def test_a_simulation_of_a_state_feedback_loads_neither_python_control_nor_scipy_signal() -> None:
    """``elab simulate`` with the plant's predefined LQR (velocity filters) and with a PID:
    the zero-order hold and Tustin of :mod:`elab.lti`, not python-control's ``c2d``
    (its imports: matplotlib and scipy.signal, over a second; issue 28). numba is what
    steps the run."""
    for controller in ("predefined", "pid:2,0.5,0.1"):
        names, proc = imported(
            "-m",
            "elab.cli",
            "simulate",
            "flexible_link",
            "--duration",
            "2",
            "--controller",
            controller,
        )
        assert proc.returncode == 0, proc.stderr[-2000:]
        assert "elab.sim.kernel" in names and "numba" in names  # the log is read right
        assert not names & {"control", "scipy.signal", "matplotlib"}, controller
        assert "2000 samples" in proc.stdout
