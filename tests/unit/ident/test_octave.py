"""Cross-check with an independent implementation: GNU Octave's control package
(``arx`` and ``n4sid``, from Debian's octave-control; `make test` installs it).
Octave's nk counts from one less than MATLAB's: its nk = MATLAB's nk − 1."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from elab.ident import IdData, iddata
from elab.ident.models import LinearModel
from elab.ident.polynomial import arx
from elab.ident.subspace import decompose, n4sid
from elab.ident.validation import compare

DRYER = Path(__file__).resolve().parents[2] / "reference" / "ident" / "dryer.dat"
OCTAVE = shutil.which("octave")
pytestmark = pytest.mark.skipif(
    OCTAVE is None,
    reason="GNU Octave is not installed (make test installs octave and octave-control)",
)
STRUCTURES = [(2, 2, 3), (4, 4, 3), (3, 2, 1), (1, 5, 2)]

SCRIPT = """pkg load control
d = load('{data}'); u = d(:,1); y = d(:,2);
ze = iddata(y(1:500) - mean(y(1:500)), u(1:500) - mean(u(1:500)), 0.08);
for s = [{structures}]
  sys = arx(ze, 'na', s(1), 'nb', s(2), 'nk', s(3) - 1);
  [num, den] = tfdata(sys);  % inputs: u, then the noise e
  num = num{{1, 1}}; den = den{{1, 1}};
  printf('%.17g ', den(1:s(1) + 1)); printf('\\n');
  printf('%.17g ', num(1:s(2))); printf('\\n');
end
"""


@pytest.fixture(scope="module")
def octave_arx(tmp_path_factory: pytest.TempPathFactory) -> list[tuple[np.ndarray, np.ndarray]]:
    script = tmp_path_factory.mktemp("octave") / "arx.m"
    cols = "; ".join(" ".join(str(v) for v in s) for s in STRUCTURES)
    script.write_text(SCRIPT.format(data=DRYER, structures=f"[{cols}]'"))
    done = subprocess.run(
        [str(OCTAVE), "--no-gui", "--quiet", "--no-window-system", str(script)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = [ln for ln in done.stdout.splitlines() if ln.strip()]
    assert len(lines) == 2 * len(STRUCTURES), done.stdout + done.stderr
    vals = [np.array([float(v) for v in ln.split()]) for ln in lines]
    return list(zip(vals[::2], vals[1::2], strict=True))


@pytest.mark.parametrize("i", range(len(STRUCTURES)))
def test_arx_equals_octave(octave_arx: list[tuple[np.ndarray, np.ndarray]], i: int) -> None:
    na, nb, nk = STRUCTURES[i]
    raw = np.loadtxt(DRYER)
    ze = iddata(raw[:, 1], raw[:, 0], 0.08)[:500].detrend()
    m = arx(ze, na, nb, nk)
    den, num = octave_arx[i]
    assert_allclose(m.parameters.A, den, rtol=1e-9, atol=1e-12)
    assert_allclose(m.parameters.B[nk:], num, rtol=1e-9, atol=1e-12)


N4SID_SCRIPT = """pkg load control
d = load('{data}'); u = d(:,1); y = d(:,2);
ze = iddata(y(1:500) - mean(y(1:500)), u(1:500) - mean(u(1:500)), 0.08);
[yd, ud] = deal(ze.y, ze.u);  % SLICOT IB01AD: the singular values n4sid plots (meth 1: N4SID)
sv = __sl_ib01ad__ (yd, ud, 16, 0, 1, 0, 1, 0, 0.0, 0.0);
for n = [3 4]
  sys = n4sid(ze, n, 's', 16);
  printf('%.17g ', sv); printf('\\n');
  p = eig(sys.a);
  printf('%.17g ', real(p)); printf('\\n'); printf('%.17g ', imag(p)); printf('\\n');
end
"""


@pytest.fixture(scope="module")
def octave_n4sid(tmp_path_factory: pytest.TempPathFactory) -> list[list[np.ndarray]]:
    script = tmp_path_factory.mktemp("octave") / "n4sid.m"
    script.write_text(N4SID_SCRIPT.format(data=DRYER))
    done = subprocess.run(
        [str(OCTAVE), "--no-gui", "--quiet", "--no-window-system", str(script)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = [ln for ln in done.stdout.splitlines() if ln.strip()]
    assert len(lines) == 6, done.stdout + done.stderr
    vals = [np.array([float(v) for v in ln.split()]) for ln in lines]
    return [vals[:3], vals[3:]]


@pytest.mark.parametrize("order", [3, 4])
def test_n4sid_equals_octave(octave_n4sid: list[list[np.ndarray]], order: int) -> None:
    """Same singular values (SLICOT IB01AD's) and the same poles (A is unique up to a
    similarity); B and D come from the R factor by both, with SLICOT's own weighting and
    rank decisions, so they are checked by fit below."""
    raw = np.loadtxt(DRYER)
    ze = iddata(raw[:, 1], raw[:, 0], 0.08)[:500].detrend()
    sv, re, im = octave_n4sid[order - 3]
    sub = decompose(ze, 16)
    assert_allclose(sub.singular_values, sv, rtol=1e-9)
    m = n4sid(ze, order, sub=sub)
    assert_allclose(np.sort_complex(m.poles), np.sort_complex(re + 1j * im), atol=1e-9)


# Public data sets at their published settings: (file, output column, input column, Ts,
# estimation samples, order, horizon). The robot arm is the lightly damped one (poles at
# |z| = 0.9988); the heat exchanger is a nonlinear process.
REFERENCE = Path(__file__).resolve().parents[2] / "reference" / "ident"
SETTINGS = {
    "dryer": ("dryer.dat", 1, 0, 0.08, 500, 4, 16),
    "robot_arm": ("robot_arm.dat", 1, 0, 1.0, 512, 4, 20),
    "exchanger": ("exchanger.dat", 2, 1, 1.0, 2000, 4, 20),
}
SLICOT_SCRIPT = """pkg load control
d = load('{path}'); y = d(:, {yc}); u = d(:, {uc}); N = {nest};
ze = iddata(y(1:N) - mean(y(1:N)), u(1:N) - mean(u(1:N)), {Ts});
sys = n4sid(ze, {n}, 's', {s});
printf('%.17g ', sys.a); printf('\\n'); printf('%.17g ', sys.b); printf('\\n');
printf('%.17g ', sys.c); printf('\\n'); printf('%.17g ', sys.d); printf('\\n');
"""


def _parts(name: str) -> tuple[IdData, IdData]:
    path, yc, uc, Ts, nest, _, _ = SETTINGS[name]
    raw = np.loadtxt(REFERENCE / path)
    y, u = raw[:, yc], raw[:, uc]
    ze = iddata(y[:nest] - y[:nest].mean(), u[:nest] - u[:nest].mean(), Ts)
    zv = iddata(y[nest:] - y[nest:].mean(), u[nest:] - u[nest:].mean(), Ts)
    return ze, zv


@pytest.fixture(scope="module")
def slicot_models(tmp_path_factory: pytest.TempPathFactory) -> dict[str, LinearModel]:
    folder = tmp_path_factory.mktemp("slicot")
    models = {}
    for name, (path, yc, uc, Ts, nest, n, s) in SETTINGS.items():
        script = folder / f"{name}.m"
        script.write_text(
            SLICOT_SCRIPT.format(
                path=REFERENCE / path, yc=yc + 1, uc=uc + 1, nest=nest, Ts=Ts, n=n, s=s
            )
        )
        done = subprocess.run(
            [str(OCTAVE), "--no-gui", "--quiet", "--no-window-system", str(script)],
            capture_output=True,
            text=True,
            timeout=120,
        )
        rows = [
            np.array([float(v) for v in ln.split()])
            for ln in done.stdout.splitlines()
            if ln.strip()
        ]
        assert len(rows) == 4, done.stdout + done.stderr
        A = rows[0].reshape(n, n, order="F")
        models[name] = LinearModel(A, rows[1], rows[2], rows[3], np.zeros(n), Ts, np.eye(1))
    return models


@pytest.mark.parametrize("name", list(SETTINGS))
def test_n4sid_fits_at_least_as_well_as_slicot(
    slicot_models: dict[str, LinearModel], name: str
) -> None:
    """Issue 16: at each data set's published setting, E-Lab's validation fits from a zero
    and from the estimated initial state are at least SLICOT's (GNU Octave's n4sid, which
    runs IB01AD/IB01BD/IB01CD) minus 0.2 points. (With B and D by simulation least
    squares the robot arm fitted 83.75 % from zero against SLICOT's 85.21 %.)"""
    ze, zv = _parts(name)
    n, s = SETTINGS[name][5:]
    ours, theirs = n4sid(ze, n, horizon=s), slicot_models[name]
    assert_allclose(np.sort_complex(ours.poles), np.sort_complex(theirs.poles), atol=1e-8)
    for x0 in ("zero", "estimate"):
        mine, slicot = compare(ours, zv, x0=x0).fit[0], compare(theirs, zv, x0=x0).fit[0]
        assert mine >= slicot - 0.2, (x0, mine, slicot)
