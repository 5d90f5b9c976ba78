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

from elab.ident import iddata
from elab.ident.polynomial import arx
from elab.ident.subspace import decompose, n4sid

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
    assert_allclose(m.parameters["A"], den, rtol=1e-9, atol=1e-12)
    assert_allclose(m.parameters["B"][nk:], num, rtol=1e-9, atol=1e-12)


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
    similarity); B and D differ by method (SLICOT solves them from the R factor, E-Lab by
    simulation least squares), so they are checked by fit in test_subspace.py."""
    raw = np.loadtxt(DRYER)
    ze = iddata(raw[:, 1], raw[:, 0], 0.08)[:500].detrend()
    sv, re, im = octave_n4sid[order - 3]
    sub = decompose(ze, 16)
    assert_allclose(sub.singular_values, sv, rtol=1e-9)
    m = n4sid(ze, order, sub=sub)
    assert_allclose(np.sort_complex(m.poles), np.sort_complex(re + 1j * im), atol=1e-9)
