"""The link model over many emulated rigs: ``python scripts/link_sweep.py [N]`` runs the
closed-loop experiment of tests/unit/ident/test_physical.py on rigs 1..N (default 30)
and prints each ratio's worst and median error against the rig's true value, and how far
the nominal model is from the rigs (docs/identification.md quotes it)."""

from __future__ import annotations

import sys

import numpy as np

from elab.ident.parameters import LinkParameters
from elab.ident.physical import link
from elab.plants.flexible_link_nonlinear import NOMINAL
from elab.rig.hardware import draw_rig_parameters
from tests.unit.ident.test_physical import closed_loop, truth

NAMES = ("a", "b", "c", "g", "sigma", "f")


def main(n: int) -> None:
    rel: dict[str, list[float]] = {k: [] for k in NAMES}
    nominal: dict[str, list[float]] = {k: [] for k in ("a", "b", "c", "g")}
    dead: list[float] = []
    q = NOMINAL
    nom = {"a": q.K_s / q.J_eq, "b": q.K_s / q.J_l, "c": q.B_eq / q.J_eq, "g": q.k_u / q.J_eq}
    for seed in range(1, n + 1):
        rig = draw_rig_parameters(seed)
        p = link(closed_loop(rig, seed)).parameters
        assert isinstance(p, LinkParameters)
        true = truth(rig)
        for k in NAMES:
            rel[k].append(abs(getattr(p, k) / true[k] - 1))
        for k in nominal:
            nominal[k].append(abs(nom[k] / true[k] - 1))
        dead.append(abs(p.u_dead - true["u_dead"]))
    print(f"{n} rigs | ratio | median error | worst error | nominal model's median, worst")
    for k in NAMES:
        v = np.array(rel[k]) * 100
        nv = np.array(nominal.get(k, [np.nan])) * 100
        print(
            f"{k} | {np.median(v):.2f} % | {v.max():.2f} % | "
            f"{np.median(nv):.1f} %, {nv.max():.1f} %"
        )
    d = np.array(dead)
    print(f"u_dead | {np.median(d):.3f} V | {d.max():.3f} V | (nominal: no dead zone)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 30)
