"""`make bench`: measure the simulation engine and write docs/benchmarks.md.

Figures are ratios against named peers measured in the same run (these shared
2-core machines vary too much for absolute times to mean much alone).
"""

from __future__ import annotations

import argparse
import math
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as `elab` runs (elab/__init__.py)
import platform
import re
import resource
import statistics
import sys
import time
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

import control as ct
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from elab.plants import get_plant  # noqa: E402
from elab.sim import Batch, RunSpec, Simulation, Square, compile_run, simulate  # noqa: E402
from tests.unit.conftest import discrete_loop  # noqa: E402

FLEX = get_plant("flexible_link")
SPEC = RunSpec(FLEX, FLEX.predefined, Square(math.radians(30), 4.0), duration=10.0)


def best_of(fn: Callable[[], object], repeat: int) -> float:
    """Median wall time of ``repeat`` calls (s), after one warm-up call."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def bench_whole_run() -> dict[str, float]:
    n = compile_run(SPEC).n_samples
    t_sim = best_of(lambda: simulate(SPEC), 50)
    run = compile_run(SPEC)
    t_compile = best_of(lambda: compile_run(SPEC), 50)
    loop = discrete_loop(compile_run(RunSpec(**{**SPEC.__dict__, "saturate": False})))
    T = np.arange(n) * run.Ts
    r = SPEC.reference.sample(0, n, run.Ts)
    t_fr = best_of(lambda: ct.forced_response(loop, T=T, U=r), 5)
    return {
        "n": n,
        "sim_ns": t_sim / n * 1e9,
        "step_ns": (t_sim - t_compile) / n * 1e9,
        "fr_ns": t_fr / n * 1e9,
        "x_realtime": n * run.Ts / t_sim,
    }


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def bench_concurrent(runs: int = 300, chunk: int = 20, seconds: float = 20.0) -> dict[str, float]:
    spec = RunSpec(
        FLEX,
        FLEX.predefined,
        Square(math.radians(30), 4.0),
        duration=3600.0,
        noise_seed=1,
        quantize=True,
    )
    batch = Batch(capacity=runs, block=1000)
    for _ in range(runs):
        batch.add(compile_run(spec))
    ticks = round(seconds / (chunk * FLEX.Ts))
    slots = list(range(runs))
    cols = [batch.columns(s) for s in slots]
    batch.advance(chunk)  # warm-up
    c0 = _cpu()
    for _ in range(ticks):
        block = batch.advance(chunk)
        # what a consumer does per run: take views of its outputs and input
        for s, (ys, _xs) in zip(slots, cols, strict=True):
            block[s, :, ys], block[s, :, 1]
    batched = (_cpu() - c0) / seconds
    sims = [Simulation(spec, block=1000) for _ in range(runs)]
    for s in sims:
        s.advance(chunk)
    per_ticks = max(1, ticks // 10)
    c0 = _cpu()
    for _ in range(per_ticks):
        for s in sims:
            s.advance(chunk)
    per_run = (_cpu() - c0) / (per_ticks * chunk * FLEX.Ts)
    return {"runs": runs, "chunk": chunk, "batched_core": batched, "per_run_core": per_run}


def engine_section() -> str:
    w, c = bench_whole_run(), bench_concurrent()
    return f"""## Simulation engine (issue 2)

### Whole run: flexible link, predefined LQR with velocity filters, ±10 V saturation, 10 s at 1 kHz

| measure | value | goal |
|---|---|---|
| `simulate()` per step, everything included (validation, ZOH, Tustin, signals) | {w["sim_ns"]:.0f} ns | ≤ 200 ns |
| stepping loop per step (the same minus `compile_run`) | {w["step_ns"]:.0f} ns | |
| faster than real time | {w["x_realtime"]:,.0f}× | ≥ 5,000× |
| peer: python-control `forced_response`, same discrete loop without saturation | {w["fr_ns"]:.0f} ns per step | |
| **ratio `forced_response` / `simulate()`** | **{w["fr_ns"] / w["sim_ns"]:.0f}×** | |

### Chunked stepping: {c["runs"]:.0f} concurrent flexible-link runs in {c["chunk"] * FLEX.Ts * 1e3:.0f} ms chunks

Each run: predefined LQR with velocity filters, quantised encoders, seeded sensor noise,
±10 V saturation. CPU time (user + system) per second of simulated (real) time:

| stepping | share of one core | goal |
|---|---|---|
| one `Batch.advance` call per chunk for all runs, then a view of each run's outputs (the engine's way) | {c["batched_core"] * 100:.2f} % | ≤ 5 % |
| peer: one `Simulation.advance` call per run per chunk | {c["per_run_core"] * 100:.1f} % | |
| **ratio per-run / batched** | **{c["per_run_core"] / c["batched_core"]:.0f}×** | |
"""


def loop_section() -> str:
    from tests.bench.loop import loop_section as section

    return section()


def server_section() -> str:
    from tests.bench.server import server_section as section

    return section()


def load_section() -> str:
    from tests.bench.load import load_section as section

    return section()


def live_plot_section() -> str:
    from tests.bench.liveplot import bench_live_plot

    return "## Browser app (issue 4)\n\n" + bench_live_plot()


def startup_section() -> str:
    from tests.bench.startup import bench_startup

    return bench_startup()


def page_section() -> str:
    from tests.bench.page import bench_page

    return bench_page()


def downloads_section() -> str:
    from tests.bench.downloads import bench_downloads

    return bench_downloads()


def ident_section() -> str:
    from tests.bench.ident import bench_ident

    return "## Identification (issue 5)\n\n" + bench_ident()


def controllers_section() -> str:
    from tests.bench.controllers import bench_controllers

    return bench_controllers()


def rig_section() -> str:
    from tests.bench.rig import rig_section as section

    return section()


def cli_section() -> str:
    from tests.bench.cli import bench_cli

    return bench_cli()


def store_section() -> str:
    from tests.bench.store import bench_store

    return bench_store()


def broker_section() -> str:
    from tests.bench.broker import bench_broker

    return bench_broker()


#: name → function returning the section's markdown, in document order
SECTIONS: dict[str, Callable[[], str]] = {
    "engine": engine_section,
    "loop": loop_section,
    "server": server_section,
    "load": load_section,
    "liveplot": live_plot_section,
    "page": page_section,
    "startup": startup_section,
    "downloads": downloads_section,
    "ident": ident_section,
    "controllers": controllers_section,
    "cli": cli_section,
    "rig": rig_section,
    "store": store_section,
    "broker": broker_section,
}
OUT = ROOT / "docs" / "benchmarks.md"


def header() -> str:
    now = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    return f"""# Benchmarks

Written by `make bench` (`tests/bench/run.py`; one section: `--only NAME`, names
{", ".join(SECTIONS)}); last run {now}; {platform.processor() or platform.machine()},
{os.cpu_count()} cores, Python {platform.python_version()}, NumPy {np.__version__},
python-control {ct.__version__}. Shared 2-core machines: compare the ratios, not the
absolutes; each section says when and under what load it was measured.
"""


def _blocks(text: str) -> dict[str, str]:
    found = re.findall(r"<!-- bench:(\w+) -->\n(.*?)<!-- /bench:\1 -->\n", text, re.S)
    return dict(found)


def _notes(block: str) -> str:
    """A section's hand-written part (history, findings), kept when it is re-measured:
    the text from ``<!-- notes -->`` to ``<!-- /notes -->`` inside the block."""
    found = re.search(r"<!-- notes -->\n.*?<!-- /notes -->\n", block, re.S)
    return found.group(0) + "\n" if found else ""


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--only",
        action="append",
        choices=list(SECTIONS),
        help="run only this section (repeatable); the others keep their figures",
    )
    args = parser.parse_args(argv)
    blocks = _blocks(OUT.read_text(encoding="utf-8")) if OUT.exists() else {}
    for name in args.only or list(SECTIONS):
        print(f"running {name} ...", flush=True)
        when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
        blocks[name] = (
            SECTIONS[name]().rstrip() + f"\n\n_Measured {when}, load average "
            f"{os.getloadavg()[0]:.1f} at the end._\n\n" + _notes(blocks.get(name, ""))
        )
    # sections measured here, then those written by hand (the test suite's times): kept
    order = [n for n in SECTIONS if n in blocks] + [n for n in blocks if n not in SECTIONS]
    body = "".join(f"<!-- bench:{n} -->\n{blocks[n]}<!-- /bench:{n} -->\n" for n in order)
    OUT.write_text(header() + "\n" + body, encoding="utf-8")
    print(OUT.read_text(encoding="utf-8"))


if __name__ == "__main__":
    main()
