"""E-Lab's ``n4sid`` against SLICOT's (GNU Octave's control package) on public data sets,
orders 1 … 10, horizon 20: the validation fits from a zero and from the estimated initial
state, each cell's shortfall, the automatically chosen order and the time per call.

    PYTHONPATH=backend:. python scripts/subspace_vs_slicot.py [--no-time]

Both run with one BLAS thread (as ``elab`` sets it; Octave inherits the setting), so the
times compare the algorithms, not the thread pools of a shared machine.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads; Octave inherits it

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from elab.ident.subspace import choose_order, decompose
from tests.unit.ident.public_sets import (
    HORIZON,
    ORDERS,
    SETS,
    cells,
    elab_seconds,
    run_slicot,
)


def _shown(fits: np.ndarray) -> str:
    v = float(np.mean(fits))
    return f"{v:.2f}" if v > -1000 else "-1e3"


def main() -> None:
    run = run_slicot()
    table = cells(run)
    print("validation fit % (mean over outputs; below -1000 % shown as -1e3)")
    print(f"{'set':<17}{'n':>3}  {'E-Lab x0=0':>11}{'SLICOT':>9}  {'E-Lab x0':>9}{'SLICOT':>9}")
    for c in table:
        mark = "  <" if c.shortfall > 1 else ("  >" if c.shortfall < -1 else "")
        f = [_shown(v) for v in (c.zero, c.slicot_zero, c.x0, c.slicot_x0)]
        print(f"{c.name:<17}{c.order:>3}  {f[0]:>11}{f[1]:>9}  {f[2]:>9}{f[3]:>9}{mark}")
    below = [c for c in table if c.shortfall > 1]
    above = [c for c in table if c.shortfall < -1]
    print(f"\n{len(table)} cells; {len(below)} more than 1 point below SLICOT, {len(above)} above")
    for c in sorted(below, key=lambda c: -c.shortfall)[:10]:
        print(f"  below: {c.name} n={c.order} by {c.shortfall:.2f}")
    print("\nautomatic order (validation fit from x0 = 0 of the chosen and of the best order)")
    for s in SETS:
        ze, _ = s.records()
        choice = choose_order(decompose(ze, HORIZON), ORDERS)
        fits = {c.order: float(np.mean(c.zero)) for c in table if c.name == s.name}
        best = max(fits, key=lambda n: fits[n])
        print(
            f"  {s.name:<17} chose {choice.best:>2} ({fits[choice.best]:6.2f} %), best "
            f"{best:>2} ({fits[best]:6.2f} %): {choice.reason}"
        )
    if "--no-time" in sys.argv:
        return
    print("\nmean time per n4sid call (orders 1 … 10, s = 20)")
    for s in SETS:
        ours, theirs = elab_seconds(s), run.seconds[s.name]
        print(
            f"  {s.name:<17} E-Lab {1e3 * ours:7.2f} ms  Octave {1e3 * theirs:7.2f} ms  "
            f"ratio {ours / theirs:4.2f}"
        )


if __name__ == "__main__":
    main()
