"""The command line's start (issue 16, item 8): ``elab identify --model n4sid:4`` on the
hair dryer, the whole process timed from outside, against GNU Octave doing the same in
its own process (load the control package and the data, split, detrend, ``n4sid``, print
the fit); and the imports of ``elab.cli`` alone and of that command
(``python -X importtime``). ``elab simulate`` (issue 28) against a plain python-control
script that runs the same closed loop (the link under its LQR through the velocity
filters, 10 s at 1 kHz): its ``c2d`` and a numpy loop."""

from __future__ import annotations

import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DRYER = ROOT / "tests" / "reference" / "ident" / "dryer.dat"
IDENTIFY = ["identify", str(DRYER), "--input", "c1", "--output", "c2", "--Ts", "0.08"]
N4SID = [*IDENTIFY, "--model", "n4sid:4"]
REPEAT = 5
SIMULATE = ["simulate", "flexible_link", "--duration", "10"]
# the peer of `elab simulate`: python-control discretises the plant and the controller as
# the lab realises them, and a numpy loop steps 10,000 samples (no noise, no saturation)
PEER_SIMULATE = """
import control as ct
import numpy as np
from elab.design.realise import realise
from elab.plants import PLANTS
plant = PLANTS["flexible_link"]
real = realise(plant, plant.predefined, all_pid_states=True)
P = ct.c2d(ct.ss(plant.A, plant.B, plant.C, plant.D), plant.Ts)
K = ct.c2d(real.ss(), plant.Ts, method="tustin")
Ad, Bd, C = np.asarray(P.A), np.asarray(P.B)[:, 0], np.asarray(plant.C)
Ac, Bc, Cc, Dc = (np.asarray(m) for m in (K.A, K.B, K.C, K.D))
x, xi, theta = np.zeros(plant.nx), np.zeros(Ac.shape[0]), np.empty(10_000)
for k in range(10_000):
    w = np.concatenate([[1.0], C @ x])
    u = (Cc @ xi + Dc @ w)[0]
    xi = Ac @ xi + Bc @ w
    x = Ad @ x + Bd * u
    theta[k] = x[0]
print(f"theta max {theta.max():.4g}")
"""
# MATLAB's standard experiment, as `elab identify` runs it: samples 1…500 estimate,
# 501…1000 validate, each detrended by its own mean; the fit simulated from x₀ = 0.
OCTAVE_SCRIPT = """pkg load control
d = load('{data}'); y = d(:, 2); u = d(:, 1);
ye = y(1:500) - mean(y(1:500)); ue = u(1:500) - mean(u(1:500));
yv = y(501:end) - mean(y(501:end)); uv = u(501:end) - mean(u(501:end));
sys = n4sid(iddata(ye, ue, 0.08), 4, 's', 16);
yh = lsim(ss(sys.a, sys.b, sys.c, sys.d, 0.08), uv);
printf('n4sid 4: validation fit %.2f %%\\n', 100 * (1 - norm(yv - yh) / norm(yv - mean(yv))));
"""


def _wall(argv: list[str]) -> tuple[float, str]:
    """Median wall time (s) of ``REPEAT`` runs of ``argv`` after one warm-up run (the
    files in the page cache), and the last run's standard output."""
    times, out = [], ""
    for i in range(REPEAT + 1):
        t0 = time.perf_counter()
        done = subprocess.run(argv, capture_output=True, text=True, timeout=300, check=False)
        elapsed = time.perf_counter() - t0
        if done.returncode != 0:
            raise RuntimeError(f"{argv[0]} exited {done.returncode}: {done.stderr[-2000:]}")
        out = done.stdout
        if i:
            times.append(elapsed)
    return statistics.median(times), out


def import_seconds(stderr: str) -> float:
    """The imports' total in a ``-X importtime`` log: the sum of the top-level modules'
    cumulative times."""
    total = 0
    for line in stderr.splitlines():
        parts = line.split("|")
        if line.startswith("import time:") and len(parts) == 3 and parts[1].strip().isdigit():
            name = parts[2]
            if len(name) - len(name.lstrip()) == 1:  # not nested in another import
                total += int(parts[1])
    return total / 1e6


def _imports(args: list[str]) -> float:
    """Median of ``REPEAT`` import totals of ``python -X importtime *args`` (s)."""
    totals = []
    for _ in range(REPEAT):
        done = subprocess.run(
            [sys.executable, "-X", "importtime", *args],
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
            cwd=ROOT,
        )
        totals.append(import_seconds(done.stderr))
    return statistics.median(totals)


def _fit(out: str) -> str:
    found = re.search(r"n4sid 4: validation fit ([\d.]+) %", out)
    return f"{found.group(1)} %" if found else "?"


def bench_cli() -> str:
    exe = shutil.which("elab", path=str(Path(sys.executable).parent))
    elab = [exe] if exe else [sys.executable, "-m", "elab.cli"]
    ours, out = _wall([*elab, *N4SID])
    sim, _ = _wall([*elab, *SIMULATE])
    peer_sim, _ = _wall([sys.executable, "-c", PEER_SIMULATE])
    sim_imports = _imports(["-m", "elab.cli", *SIMULATE])
    bare, _ = _wall([sys.executable, "-c", "pass"])
    cli_imports = _imports(["-c", "import elab.cli"])
    n4sid_imports = _imports(["-m", "elab.cli", *N4SID])
    octave = shutil.which("octave-cli") or shutil.which("octave")
    if octave is None:
        theirs, octave_out, ratio = float("nan"), "", "—"
    else:
        with tempfile.TemporaryDirectory() as tmp:
            script = Path(tmp) / "n4sid.m"
            script.write_text(OCTAVE_SCRIPT.format(data=DRYER))
            theirs, octave_out = _wall(
                [octave, "--no-gui", "--quiet", "--no-window-system", str(script)]
            )
        ratio = f"{theirs / ours:.2f}×"
    return f"""## The command line (issue 16)

### `elab identify … --model n4sid:4` against GNU Octave, each a whole process

The hair dryer (`tests/reference/ident/dryer.dat`, samples 1…500 estimate, 501…1000
validate), a subspace model of order 4, horizon 16. E-Lab: `elab identify
tests/reference/ident/dryer.dat --input c1 --output c2 --Ts 0.08 --model n4sid:4` (which
also tabulates the singular values and the orders 1…10 it would choose from); Octave:
`octave --no-gui --quiet --no-window-system` on a script that loads the control package
and the data and prints the same fit (`tests/bench/cli.py`). Median wall time of
{REPEAT} runs after a warm-up, timed from outside.

| measure | E-Lab | Octave | Octave / E-Lab |
|---|---|---|---|
| the whole command | {ours:.3f} s | {theirs:.3f} s | {ratio} |
| validation fit it prints (simulation from x₀ = 0) | {_fit(out)} | {_fit(octave_out)} | |
| peer: the Python interpreter alone (`python -c pass`) | {bare:.3f} s | | |

### `elab simulate flexible_link --duration 10` against a python-control script

The link under its predefined LQR (velocity filters), 10 s at 1 kHz, each a whole process
timed from outside (median of {REPEAT} after a warm-up). The peer imports python-control,
discretises the plant (ZOH) and the same controller (Tustin) with its `c2d` and steps a
plain numpy loop (no noise, quantisation or saturation: less work than the lab's run).

| measure | `elab simulate` | peer: python-control script | goal |
|---|---|---|---|
| the whole command | {sim:.3f} s | {peer_sim:.3f} s | ≤ 0.4 s |
| **ratio** | **{sim / peer_sim:.2f}×** | 1 | |

### Imports (`python -X importtime`, sum of the top-level modules, median of {REPEAT})

| imports of | time | goal |
|---|---|---|
| `import elab.cli` | {cli_imports:.3f} s | |
| `elab simulate flexible_link --duration 10` (numpy, scipy.linalg, numba; no python-control, scipy.signal or matplotlib) | {sim_imports:.3f} s | |
| `elab identify … --model n4sid:4` (numpy, scipy.linalg, elab.ident; no python-control, scipy.signal or numba) | {n4sid_imports:.3f} s | < 0.5 s |
"""
