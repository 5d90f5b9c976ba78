"""The stepping loop against its C twin (issue 28, item 4): ``simulate()``, the compiled
kernel alone (`elab.sim.kernel.advance` on prepared arrays) and the same update in C
(`tests/bench/kernel.c`, gcc -O3 and -O2, checked bit for bit against the kernel), per
step, on the flexible link with its predefined LQR, velocity filters, ±10 V saturation,
quantised encoders and seeded sensor noise. min / median / max of 5 (3 at 10⁶)."""

from __future__ import annotations

import ctypes
import math
import os
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from elab.plants import get_plant
from elab.sim import Batch, RunSpec, Square, compile_run, kernel, simulate

HERE = Path(__file__).parent
FLEX = get_plant("flexible_link")


def spec(n: int) -> RunSpec:
    return RunSpec(
        FLEX,
        FLEX.predefined,
        Square(math.radians(30), 4.0),
        duration=n * FLEX.Ts,
        noise_seed=1,
        quantize=True,
    )


def _times(fn: Callable[[], object], repeat: int) -> list[float]:
    fn()  # warm-up (compilation, first-touch of the pages)
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def _compiled(opt: str, where: Path) -> ctypes.CDLL:
    lib = where / f"kernel{opt}.so"
    subprocess.run(
        ["gcc", opt, "-shared", "-fPIC", str(HERE / "kernel.c"), "-o", str(lib), "-lm"],
        check=True,
    )
    return ctypes.CDLL(str(lib))


class Loop:
    """One run's arrays as the batch holds them, and the kernel and the C loop on them."""

    def __init__(self, n: int) -> None:
        run = compile_run(spec(n))
        batch = Batch(capacity=1, block=n)
        batch.add(run)
        self.n, self.a, self.use_state = n, batch._a, batch._use_state
        self.E = 2 + FLEX.ny
        self.a["exo"][0, :, : self.E] = run.exogenous(0, n)
        self.x0, self.xc0 = self.a["x"].copy(), self.a["xc"].copy()
        W = 2 + FLEX.ny + FLEX.nx
        self.out = np.zeros((1, n, W))
        self.out_c = np.zeros((n, W))
        self.exo_c = np.ascontiguousarray(self.a["exo"][0, :, : self.E])

    def reset(self) -> None:
        self.a["x"][:], self.a["xc"][:] = self.x0, self.xc0

    def numba(self) -> None:
        self.reset()
        a = self.a
        kernel.advance(
            np.zeros(1, dtype=np.int64), self.n, a["Ad"], a["Bd"], a["C"], a["Ac"],
            a["Bc"], a["Cc"], a["Dc"], a["Lw"], self.use_state, a["u_lim"], a["quantum"],
            a["x"], a["xc"], a["exo"], np.zeros(1, dtype=np.int64), a["y_op"], a["x_op"],
            self.out,
        )  # fmt: skip

    def c(self, lib: ctypes.CDLL) -> None:
        self.reset()
        a = self.a
        p = lambda arr: np.ascontiguousarray(arr).ctypes.data_as(ctypes.c_void_p)  # noqa: E731
        x, xc = a["x"][0], a["xc"][0]  # rows of C-contiguous arrays: written in place
        lib.advance(
            ctypes.c_long(self.n), ctypes.c_long(FLEX.nx), ctypes.c_long(FLEX.ny),
            ctypes.c_long(xc.shape[0]), ctypes.c_long(a["Dc"].shape[1] - 1),
            ctypes.c_long(self.E), p(a["Ad"][0]), p(a["Bd"][0]), p(a["C"][0]), p(a["Ac"][0]),
            p(a["Bc"][0]), p(a["Cc"][0]), p(a["Dc"][0]), p(a["Lw"][0]),
            ctypes.c_long(int(self.use_state[0])), ctypes.c_double(float(a["u_lim"][0])),
            p(a["quantum"][0]), p(x), p(xc), p(self.exo_c), p(a["y_op"][0]), p(a["x_op"][0]),
            p(self.out_c),
        )  # fmt: skip


def _ns(times: list[float], n: int) -> list[float]:
    return [t / n * 1e9 for t in times]


def _spread(xs: list[float]) -> str:
    return f"{min(xs):.0f} / {statistics.median(xs):.0f} / {max(xs):.0f}"


Row = tuple[int, list[float], list[float], list[float], list[float], list[float], bool]


def _measure(n: int, libs: dict[str, ctypes.CDLL]) -> Row:
    repeat = 5 if n < 1_000_000 else 3
    loop = Loop(n)
    loop.numba()
    same = True
    for lib in libs.values():
        loop.c(lib)
        same &= np.array_equal(loop.out[0].view(np.int64), loop.out_c.view(np.int64))
    k = _ns(_times(loop.numba, repeat), n)
    c3 = _ns(_times(lambda: loop.c(libs["-O3"]), repeat), n)
    c2 = _ns(_times(lambda: loop.c(libs["-O2"]), repeat), n)
    s = spec(n)
    sim = _ns(_times(lambda: simulate(s), repeat), n)
    comp = _ns(_times(lambda: compile_run(s), repeat), n)
    return n, sim, comp, k, c3, c2, same


def loop_section() -> str:
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        libs = {opt: _compiled(opt, Path(tmp)) for opt in ("-O3", "-O2")}
        rows = [_measure(n, libs) for n in (10_000, 1_000_000)]
    med = statistics.median
    ratios = [
        (n, med(sim) / med(k), med(k) / med(c3), med(k) / med(c2))
        for n, sim, _, k, c3, c2, _ in rows
    ]
    table = "\n".join(
        f"| {n:,} | {_spread(sim)} | {_spread(comp)} | {_spread(k)} | {_spread(c3)} | "
        f"{_spread(c2)} | {'yes' if same else '**NO**'} |"
        for n, sim, comp, k, c3, c2, same in rows
    )
    ratio = "\n".join(
        f"| {n:,} | **{sk:.2f}×** | **{kc3:.2f}×** | {kc2:.2f}× |" for n, sk, kc3, kc2 in ratios
    )
    return f"""## The stepping loop against C (issue 28)

{" ".join((__doc__ or "").split())}

ns per step:

| samples | `simulate()` | of it `compile_run` | the kernel alone | C -O3 | C -O2 | bit-identical |
|---:|---|---|---|---|---|---|
{table}

| samples | `simulate()` / kernel (goal ≤ 1.5) | kernel / C -O3 (goal ≤ 1.5) | kernel / C -O2 |
|---:|---|---|---|
{ratio}

Load average {load0:.1f} before, {os.getloadavg()[0]:.1f} after.
"""
