"""The offline CLI: same numbers as the library, clear errors, exit code 2 on bad input."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from elab import design
from elab.cli import main
from elab.cli.arguments import parse_quantity
from elab.plants import get_plant


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_analyze_json_matches_the_library(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "analyze", "flexible_link", "--json")
    data = json.loads(out)
    assert code == 0
    assert data["stability"]["verdict"] == "marginally stable"
    assert data["controllability"]["rank"] == 4
    lib = design.analyze(get_plant("flexible_link"))
    np.testing.assert_allclose(data["transfer_functions"][0]["num"], lib.transfer_functions[0].num)
    assert data["predefined"]["verdict"] == "asymptotically stable"
    # seed-reproduction.md: the link's LQR step rises in 0.34 s with 1.75 % overshoot
    assert data["predefined"]["unit_step"]["rise_time"] == pytest.approx(0.342, abs=2e-3)
    assert data["predefined"]["unit_step"]["overshoot"] == pytest.approx(1.75, abs=0.02)
    assert data["predefined"]["margins"]["gain_margin_db"] is None  # ∞: JSON null
    assert data["predefined"]["margins"]["phase_margin_deg"] == pytest.approx(47.4, abs=0.1)


def test_analyze_text_explains_a_negative_gain_margin(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "analyze", "double_pendulum")
    assert code == 0
    assert "open loop: unstable — eigenvalue 5.222 in the right half-plane" in out
    assert "the open loop is unstable" in out.splitlines()[-1]


def test_design_lqr_prints_the_seed_gain(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(
        capsys, "design", "lqr", "flexible_link", "--Q", "400,1e4,3,2", "--R", "1", "--json"
    )
    # seed eq. 4.6, printed to 4 decimals; the last entry differs by 6.5e-5 (seed-reproduction.md)
    np.testing.assert_allclose(json.loads(out)["K"], [20, -93.5614, 3.3621, 0.9623], atol=1e-4)
    assert code == 0


def test_design_place_puts_the_poles(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(
        capsys, "design", "place", "flexible_link", "--poles=-10,-20,-5+5j,-5-5j", "--json"
    )

    def key(z: complex) -> tuple[float, float]:
        return (z.real, z.imag)

    poles = sorted((complex(*z) for z in json.loads(out)["closed_loop_poles"]), key=key)
    want = sorted([-10, -20, -5 + 5j, -5 - 5j], key=key)
    assert code == 0
    np.testing.assert_allclose(poles, want, rtol=1e-8)


def test_simulate_writes_a_self_describing_csv(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    out_file = tmp_path / "run.csv"
    code, _, _ = run(
        capsys,
        "simulate",
        "flexible_link",
        "--signal",
        "square",
        "--amplitude",
        "30deg",
        "--period",
        "4",
        "--duration",
        "10",
        "--out",
        str(out_file),
    )
    lines = out_file.read_text().splitlines()
    header = [line for line in lines if line.startswith("#")]
    assert code == 0
    assert any("plant: flexible_link" in h for h in header)
    assert any("controller: StateFeedback" in h for h in header)
    assert any("signal: Square(amplitude=0.523599, period=4" in h for h in header)
    assert "# sample time: 0.001 s" in header
    assert any(h.startswith("# units: t [s], r [rad], u [V], theta [rad]") for h in header)
    data = np.loadtxt(out_file, delimiter=",", comments="#", skiprows=len(header) + 1)
    assert data.shape == (10_000, 9)
    assert np.max(np.abs(data[:, 2])) <= 10.0  # saturated input
    np.testing.assert_allclose(np.abs(data[:, 1]), math.radians(30))


def test_diverging_run_is_reported(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(
        capsys, "simulate", "flexible_link", "--controller", "K:20,20,20,20", "--no-saturation"
    )
    assert code == 0 and "DIVERGED at t =" in out


@pytest.mark.parametrize(
    ("argv", "field"),
    [
        (["design", "lqr", "flexible_link", "--Q", "1,2,nan,4"], "Q"),
        (["design", "lqr", "flexible_link", "--Q", "1,2,3"], "Q"),
        (["design", "lqr", "flexible_link", "--Q", "1,1,1,1", "--R", "0"], "R"),
        (["design", "lqr", "flexible_link", "--Q=-1,1,1,1"], "Q"),
        (["design", "place", "flexible_link", "--poles", "1,2"], "poles"),
        (["simulate", "flexible_link", "--Ts", "0"], "Ts"),
        (["simulate", "flexible_link", "--Ts", "0.05"], "Ts"),
        (["simulate", "flexible_link", "--duration", "-1"], "duration"),
        (["simulate", "flexible_link", "--amplitude", "thirty"], "signal.amplitude"),
        (["simulate", "flexible_link", "--controller", "K:1,2"], "controller.K"),
        (["simulate", "flexible_link", "--signal", "sine"], "signal.frequency"),
        (["analyze", "crane"], "unknown plant 'crane'"),
    ],
)
def test_bad_input_exits_2_naming_the_field(
    capsys: pytest.CaptureFixture[str], argv: list[str], field: str
) -> None:
    code, _, err = run(capsys, *argv)
    assert code == 2
    assert err.startswith(f"error: {field}")


def test_console_script_exits_2_on_bad_input() -> None:
    exe = shutil.which("elab", path=str(Path(sys.executable).parent))
    assert exe is not None, "the console script `elab` is not installed"
    proc = subprocess.run(
        [exe, "design", "lqr", "flexible_link", "--Q", "1,1,1"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 2
    assert "error: Q" in proc.stderr and "Traceback" not in proc.stderr


def test_quantities_take_units() -> None:
    assert parse_quantity("30deg") == pytest.approx(math.radians(30))
    assert parse_quantity("250mm") == pytest.approx(0.25)
    assert parse_quantity("-2.5") == -2.5


DRYER = Path(__file__).resolve().parents[1] / "reference" / "ident" / "dryer.dat"
IDENTIFY = ["identify", str(DRYER), "--input", "c1", "--output", "c2", "--Ts", "0.08"]


@pytest.mark.parametrize(
    ("extra", "correlation", "spectral"),
    [
        ((), True, True),  # nothing asked: the analyses, to start with
        (("--model", "arx:2,2,3"), False, False),  # a model alone: that model
        (("--search", "arx:1-2,1-2,3"), False, False),
        (("--sine", "0.5"), False, False),
        (("--model", "arx:2,2,3", "--analyses", "correlation"), True, False),
        (("--model", "arx:2,2,3", "--analyses", "spectral"), False, True),
        (("--model", "arx:2,2,3", "--analyses", "all"), True, True),
        (("--analyses", "spectral, correlation"), True, True),
        (("--analyses", "none"), False, False),
    ],
)
def test_identify_runs_only_the_analyses_asked_for(
    capsys: pytest.CaptureFixture[str], extra: tuple[str, ...], correlation: bool, spectral: bool
) -> None:
    code, out, err = run(capsys, *IDENTIFY, *extra)
    assert code == 0, err
    # the hair dryer's delay is 3 samples (tests/reference/ident/README.md)
    assert ("correlation analysis: delay 3 samples" in out) is correlation
    assert ("spectral analysis (lag window 30)" in out) is spectral
    code, out, err = run(capsys, *IDENTIFY, *extra, "--json")
    assert code == 0, err
    result = json.loads(out)
    a = result["analyses"]  # the wire has every key: null when not run
    assert (a["correlation"] is not None, a["spectral"] is not None) == (correlation, spectral)
    models = [m["name"] for m in result["models"]]
    assert models == (["arx 2 2 3"] if "arx:2,2,3" in extra else [])


@pytest.mark.parametrize("value", ["fourier", "", ",", "all,none", "correlation,none", "Spectral"])
def test_identify_names_a_bad_analyses_value(
    capsys: pytest.CaptureFixture[str], value: str
) -> None:
    code, out, err = run(capsys, *IDENTIFY, "--analyses", value)
    assert code == 2 and out == ""
    assert err == (
        f"error: --analyses: got {value!r}; allowed: correlation, spectral (comma-separated), "
        "all or none\n"
    )


def test_migrate_says_what_it_did_and_refuses_a_file_that_is_no_store(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("ELAB_DATABASE_URL", raising=False)
    data = str(tmp_path / "data")
    code, out, _ = run(capsys, "migrate", "--data", data)
    assert code == 0 and out.strip().endswith("elab.sqlite3: schema version 0 -> 9")
    code, out, _ = run(capsys, "migrate", "--data", data)
    assert code == 0 and out.strip().endswith("schema version 9, current")
    empty, text = tmp_path / "empty", tmp_path / "notes.txt"
    empty.touch()
    text.write_text("not a database\n" * 100)
    for bad, why in ((empty, "has no E-Lab schema"), (text, "this is not one")):
        code, _, err = run(capsys, "migrate", "--data", str(tmp_path / "d2"), "--from", str(bad))
        assert code == 2 and "--from" in err and why in err, err
    assert empty.stat().st_size == 0 and not (tmp_path / "d2").exists()  # nothing written
    code, _, err = run(capsys, "migrate", "--data", data, "--from", data + "/elab.sqlite3")
    assert code == 2 and "another store than the one migrated" in err
