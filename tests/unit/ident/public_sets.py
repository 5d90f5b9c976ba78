"""Public data sets for comparing E-Lab's ``n4sid`` with SLICOT's (GNU Octave's control
package), and one GNU Octave run that identifies every (data set, order) cell.

Each set is split into an estimation and a validation record, each detrended by its own
mean; both tools see the same arrays (written to one file per set). Provenance, columns
and sample times: tests/reference/ident/*.md (public_sets.md for the sets added for
issue 26)."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from elab.ident import IdData, iddata
from elab.ident.models import LinearModel
from elab.ident.subspace import decompose, n4sid
from elab.ident.validation import compare

Array = NDArray[np.float64]
REFERENCE = Path(__file__).resolve().parents[2] / "reference" / "ident"
HORIZON = 20
ORDERS = range(1, 11)


@dataclass(frozen=True)
class PublicSet:
    """A data file's columns (0-based), sample time [s, or 1 when the source gives none]
    and the number of estimation samples (the rest validates)."""

    name: str
    file: str
    inputs: tuple[int, ...]
    outputs: tuple[int, ...]
    Ts: float
    estimation: int

    def records(self) -> tuple[IdData, IdData]:
        raw = _load(REFERENCE / self.file)
        u, y = raw[:, list(self.inputs)], raw[:, list(self.outputs)]
        n = self.estimation
        ze = iddata(y[:n] - y[:n].mean(axis=0), u[:n] - u[:n].mean(axis=0), self.Ts)
        zv = iddata(y[n:] - y[n:].mean(axis=0), u[n:] - u[n:].mean(axis=0), self.Ts)
        return ze, zv


def _load(path: Path) -> Array:
    if path.suffix == ".csv":  # the cascaded tanks: uEst, uVal, yEst, yVal, Ts
        d = np.genfromtxt(path, delimiter=",", skip_header=1, usecols=(0, 1, 2, 3))
        return np.vstack([d[:, [0, 2]], d[:, [1, 3]]])  # u, y: estimation, then validation
    return np.loadtxt(path)


SETS = (
    PublicSet("dryer", "dryer.dat", (0,), (1,), 0.08, 500),
    PublicSet("robot_arm", "robot_arm.dat", (0,), (1,), 1.0, 512),
    PublicSet("exchanger", "exchanger.dat", (1,), (2,), 1.0, 2000),
    PublicSet("cd_player_arm", "cd_player_arm.dat", (0, 1), (2, 3), 1.0, 1024),
    PublicSet("heating_system", "heating_system.dat", (1,), (2,), 2.0, 400),
    PublicSet("thermic_res_wall", "thermic_res_wall.dat", (0, 1), (2,), 10.0, 840),
    PublicSet("glassfurnace", "glassfurnace.dat", (1, 2, 3), (4, 5, 6, 7, 8, 9), 1.0, 624),
    PublicSet("ballbeam", "ballbeam.dat", (0,), (1,), 0.1, 500),
    PublicSet("dryer2", "dryer2.dat", (1, 2, 3), (4, 5, 6), 10.0, 434),
    PublicSet("evaporator", "evaporator.dat", (0, 1, 2), (3, 4, 5), 1.0, 3153),
    PublicSet("winding", "winding.dat", (0, 1, 2, 3, 4), (5, 6), 0.1, 1250),
    PublicSet("pH", "pHdata.dat", (1, 2), (3,), 10.0, 1000),
    PublicSet("cascaded_tanks", "cascaded_tanks.csv", (0,), (1,), 4.0, 1024),
)

OCTAVE_SCRIPT = """pkg load control
warning('off', 'all');
for k = 1:numel(files)
  d = load(files{k}); ny = nys(k); N = ests(k);
  ze = iddata(d(1:N, 1:ny), d(1:N, ny+1:end), 1);
  best = inf;
  for rep = 1:3
    t0 = tic;
    for n = orders, sys{n} = n4sid(ze, n, 's', horizon); end
    best = min(best, toc(t0));
  end
  printf('seconds %s %.9g\\n', names{k}, best / numel(orders));
  for n = orders
    printf('cell %s %d\\n', names{k}, n);
    printf('%.17g ', sys{n}.a); printf('\\n'); printf('%.17g ', sys{n}.b); printf('\\n');
    printf('%.17g ', sys{n}.c); printf('\\n'); printf('%.17g ', sys{n}.d); printf('\\n');
  end
end
"""


@dataclass(frozen=True)
class SlicotRun:
    """SLICOT's models per (set name, order) and its mean time per ``n4sid`` call [s]."""

    models: dict[tuple[str, int], LinearModel]
    seconds: dict[str, float]


def octave() -> str | None:
    return shutil.which("octave-cli") or shutil.which("octave")


def run_slicot(sets: tuple[PublicSet, ...] = SETS, orders: range = ORDERS) -> SlicotRun:
    """Every cell in one Octave process (``n4sid(ze, n, 's', 20)``, the estimation record
    as E-Lab sees it)."""
    exe = octave()
    if exe is None:
        raise RuntimeError("GNU Octave is not installed (octave-cli with octave-control)")
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for s in sets:
            ze, _ = s.records()
            path = Path(tmp) / f"{s.name}.txt"
            np.savetxt(path, np.hstack([ze.y, ze.u]), fmt="%.17g")
            files.append(path)
        script = Path(tmp) / "cells.m"
        head = (
            f"files = {{{', '.join(repr(str(f)) for f in files)}}};\n"
            f"names = {{{', '.join(repr(s.name) for s in sets)}}};\n"
            f"nys = [{' '.join(str(len(s.outputs)) for s in sets)}];\n"
            f"ests = [{' '.join(str(s.estimation) for s in sets)}];\n"
            f"orders = {orders.start}:{orders.stop - 1}; horizon = {HORIZON};\n"
        )
        script.write_text(head.replace('"', "'") + OCTAVE_SCRIPT)
        done = subprocess.run(
            [exe, "--no-gui", "--quiet", "--no-window-system", str(script)],
            capture_output=True,
            text=True,
            timeout=600,
        )
    return _parse(done.stdout, sets, done.stderr)


def _parse(out: str, sets: tuple[PublicSet, ...], err: str) -> SlicotRun:
    by_name = {s.name: s for s in sets}
    lines = [ln for ln in out.splitlines() if ln.strip()]
    models: dict[tuple[str, int], LinearModel] = {}
    seconds: dict[str, float] = {}
    i = 0
    while i < len(lines):
        words = lines[i].split()
        if words[0] == "seconds":
            seconds[words[1]] = float(words[2])
            i += 1
            continue
        if words[0] != "cell":
            raise RuntimeError(f"unexpected Octave output {lines[i]!r}: {err}")
        s, n = by_name[words[1]], int(words[2])
        nu, ny = len(s.inputs), len(s.outputs)
        a, b, c, d = (np.array([float(v) for v in ln.split()]) for ln in lines[i + 1 : i + 5])
        models[(s.name, n)] = LinearModel(
            a.reshape(n, n, order="F"),
            b.reshape(n, nu, order="F"),
            c.reshape(ny, n, order="F"),
            d.reshape(ny, nu, order="F"),
            np.zeros((n, ny)),
            s.Ts,
            np.eye(ny),
        )
        i += 5
    missing = [(s.name, n) for s in sets for n in ORDERS if (s.name, n) not in models]
    if missing:
        raise RuntimeError(f"Octave returned no model for {missing[:3]} …: {err[-2000:]}")
    return SlicotRun(models, seconds)


USELESS = -100.0  # a fit below this (error over twice the spread) is no model at all


@dataclass(frozen=True)
class Cell:
    """Validation fits [%] per output from a zero and from the estimated initial state,
    E-Lab's and SLICOT's."""

    name: str
    order: int
    zero: Array
    x0: Array
    slicot_zero: Array
    slicot_x0: Array

    @property
    def shortfall(self) -> float:
        """How far E-Lab's fit falls below SLICOT's, the worst output of either start
        (points; negative: above). Where both fits are below :data:`USELESS` (an unstable
        plant simulated from rest: the ball and beam) neither model is of use, and the
        difference counts as none."""
        gaps = [
            np.where((ours < USELESS) & (theirs < USELESS), 0.0, theirs - ours)
            for ours, theirs in ((self.zero, self.slicot_zero), (self.x0, self.slicot_x0))
        ]
        return float(np.max(np.concatenate(gaps)))


def fit(model: LinearModel, zv: IdData, x0: str) -> Array:
    f = compare(model, zv, x0="zero" if x0 == "zero" else "estimate").fit
    return np.where(np.isfinite(f), f, -1e300)


def cells(
    run: SlicotRun,
    identify: Callable[[IdData, int], LinearModel] | None = None,
    sets: tuple[PublicSet, ...] = SETS,
) -> list[Cell]:
    """Every (set, order) cell: E-Lab's ``n4sid`` (or ``identify``) against SLICOT's."""
    out = []
    for s in sets:
        ze, zv = s.records()
        sub = decompose(ze, HORIZON)
        for n in ORDERS:
            ours = identify(ze, n) if identify else n4sid(ze, n, sub=sub)
            theirs = run.models[(s.name, n)]
            out.append(
                Cell(
                    s.name,
                    n,
                    fit(ours, zv, "zero"),
                    fit(ours, zv, "x0"),
                    fit(theirs, zv, "zero"),
                    fit(theirs, zv, "x0"),
                )
            )
    return out


def elab_seconds(s: PublicSet, repeat: int = 3) -> float:
    """E-Lab's mean time per ``n4sid(ze, n, horizon=20)`` over orders 1 … 10 (best of
    ``repeat``), each call decomposing afresh as Octave's does."""
    ze, _ = s.records()
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        for n in ORDERS:
            n4sid(ze, n, horizon=HORIZON)
        best = min(best, time.perf_counter() - t0)
    return float(best / len(ORDERS))
