"""Identification benchmark (issue 5): E-Lab against GNU Octave's control package on the
same data in the same run — the ARX order search struc(1:10, 1:10, 1:10) on 100,000
samples, and subspace identification of orders 1 … 15 on 10,000 samples — with the
numbers compared, not just the times."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.signal

from elab.ident import iddata
from elab.ident.polynomial import arx, arxstruc, struc
from elab.ident.subspace import decompose, n4sid

ORDERS = range(1, 11)
HORIZON = 20
SCRIPT = """pkg load control
d = load('{arx_file}'); N = {N};
ze = iddata(d(1:N, 2), d(1:N, 1), 1);
t0 = tic;
for na = 1:10, for nb = 1:10, for nk = 1:10
  sys = arx(ze, 'na', na, 'nb', nb, 'nk', nk - 1);  % Octave's nk = MATLAB's nk - 1
  [num, den] = tfdata(sys); num = num{{1, 1}}; den = den{{1, 1}};
  theta{{na, nb, nk}} = [den(2:na + 1), num(1:nb)];
end, end, end
printf('arx_seconds %.6f\\n', toc(t0));
for na = 1:10, for nb = 1:10, for nk = 1:10
  printf('theta %d %d %d ', na, nb, nk); printf('%.17g ', theta{{na, nb, nk}}); printf('\\n');
end, end, end
d = load('{ss_file}');
z = iddata(d(:, 2), d(:, 1), 1);
best = inf;
for rep = 1:5  % best of 5, as E-Lab's
  t0 = tic;
  for n = 1:15
    sys = n4sid(z, n, 's', {horizon});
    p{{n}} = eig(sys.a);
  end
  best = min(best, toc(t0));
end
printf('n4sid_seconds %.6f\\n', best);
sv = __sl_ib01ad__ ({{z.y{{1}}}}, {{z.u{{1}}}}, {horizon}, 0, 1, 0, 1, 0, 0.0, 0.0);
printf('sv '); printf('%.17g ', sv); printf('\\n');
for n = 1:15
  printf('poles %d ', n); printf('%.17g %.17g ', [real(p{{n}}) imag(p{{n}})]'); printf('\\n');
end
"""


def _data(rng: np.random.Generator, N: int) -> tuple[np.ndarray, np.ndarray]:
    """A 4th-order system with coloured output noise, excited by white noise."""
    u = rng.standard_normal(N)
    b, a = (
        [0, 0, 0.4, 0.3, -0.1],
        np.real(np.poly([0.9 * np.exp(0.4j), 0.9 * np.exp(-0.4j), 0.7, -0.3])),
    )
    y = scipy.signal.lfilter(b, a, u) + scipy.signal.lfilter(
        [1, 0.5], [1, -0.8], 0.1 * rng.standard_normal(N)
    )
    return u, y


def _best(fn, repeat: int = 3) -> float:  # type: ignore[no-untyped-def]
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def bench_ident() -> str:
    octave = shutil.which("octave-cli") or shutil.which("octave")
    rng = np.random.default_rng(2026)
    N = 100_000
    u, y = _data(rng, 2 * N)
    ze, zv = iddata(y[:N], u[:N], 1.0), iddata(y[N:], u[N:], 1.0)
    S = struc(ORDERS, ORDERS, ORDERS)
    search_s = _best(lambda: arxstruc(ze, zv, S))
    models: dict[tuple[int, int, int], np.ndarray] = {}

    def every_arx() -> None:
        for na, nb, nk in S:
            m = arx(ze, int(na), int(nb), int(nk))
            models[(int(na), int(nb), int(nk))] = np.r_[
                m.parameters.A[1:], m.parameters.B[int(nk) :]
            ]

    arx_s = _best(every_arx, 1)
    us, ys = _data(rng, 10_000)
    zs = iddata(ys, us, 1.0)

    def subspace(stable: bool | str = "auto") -> list[np.ndarray]:
        sub = decompose(zs, HORIZON)
        return [n4sid(zs, n, sub=sub, stable=stable).poles for n in range(1, 16)]  # type: ignore[arg-type]

    sub_s = _best(subspace, 5)  # the default: an unstable estimate also tried reflected
    ours_poles = subspace(stable=False)  # as Octave, which warns but keeps unstable A
    stabilised = sum(bool(np.any(np.abs(p) > 1)) for p in ours_poles)
    ours_sv = decompose(zs, HORIZON).singular_values
    if octave is None:
        return "GNU Octave is not installed (make test-debs installs it): no peer figures.\n"
    with tempfile.TemporaryDirectory() as tmp:
        arx_file, ss_file, script = (Path(tmp) / n for n in ("arx.txt", "ss.txt", "b.m"))
        np.savetxt(arx_file, np.c_[u[:N], y[:N]], fmt="%.17g")
        np.savetxt(ss_file, np.c_[us, ys], fmt="%.17g")
        script.write_text(SCRIPT.format(arx_file=arx_file, ss_file=ss_file, N=N, horizon=HORIZON))
        done = subprocess.run(
            [octave, "--no-gui", "--quiet", "--no-window-system", str(script)],
            capture_output=True,
            text=True,
            timeout=3600,
        )
    out: dict[str, list[str]] = {}
    thetas: dict[tuple[int, int, int], np.ndarray] = {}
    poles: dict[int, np.ndarray] = {}
    for line in done.stdout.splitlines():
        key, *vals = line.split()
        if key == "theta":
            thetas[(int(vals[0]), int(vals[1]), int(vals[2]))] = np.array(vals[3:], float)
        elif key == "poles":
            v = np.array(vals[1:], float)
            poles[int(vals[0])] = v[0::2] + 1j * v[1::2]
        elif key:
            out[key] = vals
    if len(thetas) != 1000 or len(poles) != 15:
        raise RuntimeError(f"Octave did not finish: {done.stderr[-2000:]}")
    oct_arx, oct_sub = float(out["arx_seconds"][0]), float(out["n4sid_seconds"][0])
    diffs = {
        k: float(np.max(np.abs(models[k] - thetas[k]) / np.maximum(1, np.abs(thetas[k]))))
        for k in thetas
    }
    worst = max(diffs, key=lambda k: diffs[k])
    off = sorted(k for k, v in diffs.items() if v > 1e-9)
    oct_sv = np.array(out["sv"], float)
    dsv = float(np.max(np.abs(ours_sv - oct_sv) / oct_sv))
    dpole = max(
        float(np.max(np.abs(np.sort_complex(ours_poles[n - 1]) - np.sort_complex(p))))
        for n, p in poles.items()
    )
    return f"""### Identification against GNU Octave's control package (issue 5)

The same data for both, written once to a text file for Octave (reading it is not timed):
a 4th-order system with coloured output noise, white-noise input. E-Lab runs with one
BLAS thread (as `elab` sets it); Octave {_octave_version(octave)} with control
{_control_version(octave)} (SLICOT), timed by its own `tic`/`toc`. The subspace task: best
of 5 for each; the ARX search: best of 3 for E-Lab, and one run of the 1,000 `arx` calls
for each (Octave's take two minutes).

| task | E-Lab | Octave | Octave / E-Lab | same numbers |
|---|---|---|---|---|
| ARX order search `struc(1:10, 1:10, 1:10)`: 1,000 models on 100,000 estimation samples, each with its loss on 100,000 validation samples (`arxstruc`) | {search_s:.2f} s | — (no `arxstruc`; its 1,000 `arx` calls below, without the validation) | **{oct_arx / search_s:.0f}×** | best structure as MATLAB's rule (tests) |
| the same 1,000 models by separate `arx` calls | {arx_s:.2f} s | {oct_arx:.2f} s | {oct_arx / arx_s:.1f}× | coefficients: median relative difference {np.median(list(diffs.values())):.0e}; {1000 - len(off)} of 1,000 models agree to 1e-9, {len(off)} differ by up to {diffs[worst]:.0e} ({", ".join(f"[{a} {b} {c}]" for a, b, c in off[:6])}{" …" if len(off) > 6 else ""}: Octave's least squares starts at another sample there — [2 1 2], for one, equals E-Lab's started one sample later, max(na, nb + nk) instead of MATLAB's max(na, nb + nk − 1); the published hair-dryer results follow MATLAB's) |
| subspace identification, orders 1 … 15, horizon {HORIZON}, 10,000 samples (A, B, C, D, K, x₀ each) | {sub_s:.3f} s | {oct_sub:.3f} s (`n4sid` per order) | **{oct_sub / sub_s:.1f}×** | singular values to {dsv:.0e} (relative); poles of every order to {dpole:.0e} (compared with A as estimated, as Octave keeps it; {stabilised} of the 15 orders have an unstable pole, which E-Lab's default also reflects and keeps when that fits the estimation data better — in the time) |

E-Lab's order search shares one regressor matrix per delay and solves each model from a
sub-block of its normal equations; the subspace path factorises the Hankel matrix once
for every order. Octave's `n4sid` refactorises for each order, as a user calling it per
order does.

{bench_datasets(octave)}
{bench_public_sets()}"""


def _octave_version(octave: str) -> str:
    done = subprocess.run([octave, "--version"], capture_output=True, text=True, timeout=60)
    return done.stdout.split("\n", 1)[0].rsplit(" ", 1)[-1]


def _control_version(octave: str) -> str:
    done = subprocess.run(
        [octave, "--no-gui", "--quiet", "--eval", "p = pkg('list', 'control'); disp(p{1}.version)"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    return done.stdout.strip() or "?"


DATASETS = {  # file, output column, input column, estimation samples, order, horizon
    "hair dryer": ("dryer.dat", 1, 0, 500, 4, 16),
    "flexible robot arm": ("robot_arm.dat", 1, 0, 512, 4, 20),
    "steam heat exchanger": ("exchanger.dat", 2, 1, 2000, 4, 20),
}
DATA_SCRIPT = """pkg load control
d = load('{path}'); y = d(:, {yc}); u = d(:, {uc}); N = {nest};
ze = iddata(y(1:N) - mean(y(1:N)), u(1:N) - mean(u(1:N)), 1);
best = inf;
for rep = 1:5
  t0 = tic; sys = n4sid(ze, {n}, 's', {s}); best = min(best, toc(t0));
end
printf('seconds %.6f\\n', best);
printf('%.17g ', sys.a); printf('\\n'); printf('%.17g ', sys.b); printf('\\n');
printf('%.17g ', sys.c); printf('\\n'); printf('%.17g ', sys.d); printf('\\n');
"""


def bench_datasets(octave: str) -> str:
    """Per public data set (tests/reference/ident/): subspace at its published setting,
    E-Lab against Octave's n4sid — the validation fits from x₀ = 0 and from the fitted x₀
    of both models, computed by the same code, and the time of one identification."""
    from elab.ident.models import LinearModel
    from elab.ident.validation import compare

    here = Path(__file__).resolve().parents[1] / "reference" / "ident"
    rows = []
    for name, (path, yc, uc, nest, n, s) in DATASETS.items():
        raw = np.loadtxt(here / path)
        y, u = raw[:, yc], raw[:, uc]
        ze = iddata(y[:nest] - y[:nest].mean(), u[:nest] - u[:nest].mean(), 1.0)
        zv = iddata(y[nest:] - y[nest:].mean(), u[nest:] - u[nest:].mean(), 1.0)
        ours_s = _best(lambda: n4sid(ze, n, horizon=s), 5)  # noqa: B023
        ours = n4sid(ze, n, horizon=s)
        with tempfile.TemporaryDirectory() as tmp:
            script = Path(tmp) / "d.m"
            script.write_text(
                DATA_SCRIPT.format(path=here / path, yc=yc + 1, uc=uc + 1, nest=nest, n=n, s=s)
            )
            done = subprocess.run(
                [octave, "--no-gui", "--quiet", "--no-window-system", str(script)],
                capture_output=True,
                text=True,
                timeout=600,
            )
        lines = [ln.split() for ln in done.stdout.splitlines() if ln.strip()]
        oct_s = float(lines[0][1])
        A, B, C, D = (np.array(v, float) for v in lines[1:5])
        theirs = LinearModel(A.reshape(n, n, order="F"), B, C, D, np.zeros(n), 1.0, np.eye(1))
        f = {
            (who, x0): compare(m, zv, x0=x0).fit[0]  # type: ignore[arg-type]
            for who, m in (("ours", ours), ("theirs", theirs))
            for x0 in ("zero", "estimate")
        }
        rows.append(
            f"| {name} ({path}, order {n}, s = {s}, first {nest} samples estimate) | "
            f"{f['ours', 'zero']:.2f} % / {f['ours', 'estimate']:.2f} % | "
            f"{f['theirs', 'zero']:.2f} % / {f['theirs', 'estimate']:.2f} % | "
            f"{ours_s * 1e3:.1f} ms | {oct_s * 1e3:.1f} ms | {oct_s / ours_s:.1f}× |"
        )
    return (
        "### Public data sets: subspace at their published settings (issue 16)\n\n"
        "Validation fits from x₀ = 0 / from the fitted x₀, both models scored by the same "
        "code; the time of one identification (best of 5, each timed inside its own "
        "process). Acceptance: E-Lab's fits at least SLICOT's − 0.2 points (tested in "
        "`tests/unit/ident/test_octave.py`).\n\n"
        "| data set | E-Lab | Octave (SLICOT) | E-Lab time | Octave time | Octave / E-Lab |\n"
        "|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n"
    )


def bench_public_sets() -> str:
    """Issue 26: every public data set of tests/unit/ident/public_sets.py at orders 1 … 10,
    s = 20 — the cells where E-Lab's validation fit falls more than a point below SLICOT's,
    and the mean time of one ``n4sid`` call (each decomposing afresh, as Octave's)."""
    from tests.unit.ident.public_sets import SETS, cells, elab_seconds, run_slicot

    run = run_slicot()
    table = cells(run)
    rows = []
    for s in SETS:
        mine = [c for c in table if c.name == s.name]
        below = sum(c.shortfall > 1 for c in mine)
        worst = max(c.shortfall for c in mine)
        ours, theirs = elab_seconds(s), run.seconds[s.name]
        ze, _ = s.records()
        rows.append(
            f"| {s.name} | {ze.nu} × {ze.ny} | {ze.N} | {below} | {worst:+.2f} | "
            f"{ours * 1e3:.2f} ms | {theirs * 1e3:.2f} ms | {theirs / ours:.2f}× |"
        )
    return (
        "### Public data sets at every order 1 … 10, s = 20 (issue 26)\n\n"
        "Cells (orders) whose validation fit, from x₀ = 0 or from the fitted x₀, any output, "
        "falls more than 1 point below SLICOT's, the largest shortfall (negative: E-Lab above "
        "everywhere), and the mean time of one `n4sid` call over the ten orders (best of 3). "
        "Table: `scripts/subspace_vs_slicot.py`; test: `tests/unit/ident/test_slicot_public.py`.\n\n"
        "| data set | inputs × outputs | estimation samples | cells > 1 point below | worst | "
        "E-Lab time | Octave time | Octave / E-Lab |\n"
        "|---|---|---|---|---|---|---|---|\n" + "\n".join(rows) + "\n"
    )
