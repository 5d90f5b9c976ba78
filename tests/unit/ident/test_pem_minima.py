"""OE and ARMAX on a plant whose prediction-error loss has several minima: two resonances
(at 0.5 and 2.0 rad/sample, |z| = 0.95) seen through a second-order model, which can
follow either one. Issue 16: the estimate must be the global optimum — found by an
independent brute-force reference (Gauss–Newton from many random stable starts) — in at
least 95 of 100 seeds. Measured: both find it in 100 of 100; from the one start each
had before (instrumental variables for OE, pseudo-linear regression for ARMAX) they
found it in 2 and 77.

The brute-force optima take a minute: they are computed once by
``tests/reference/pem/make.py`` and committed; a few seeds are recomputed here on every
run, so a change that moves them fails until the file is made again."""

from __future__ import annotations

import pytest

from elab.ident import iddata
from elab.ident.pem import armax, oe
from tests.reference.pem import make

SAME = 1e-3  # relative loss within which two minima are the same one
RECHECKED = (0, 37, 99)  # seeds whose brute-force optimum is computed afresh


@pytest.fixture(scope="module")
def references() -> dict[str, list[float]]:
    return make.load()["minima"]  # type: ignore[return-value]


@pytest.mark.parametrize("kind", ["oe", "armax"])
@pytest.mark.parametrize("seed", RECHECKED)
def test_the_committed_brute_force_optima_are_current(
    references: dict[str, list[float]], kind: str, seed: int
) -> None:
    fresh = make.oe_reference(seed) if kind == "oe" else make.armax_reference(seed)
    assert fresh == pytest.approx(references[kind][seed], rel=1e-6), (
        "tests/reference/pem/pem.json is stale: run python -m tests.reference.pem.make"
    )


@pytest.mark.parametrize("kind", ["oe", "armax"])
def test_the_global_optimum_is_found_in_95_of_100_seeds(
    references: dict[str, list[float]], kind: str
) -> None:
    assert len(references[kind]) == len(make.SEEDS)
    found, single = 0, 0
    for seed in make.SEEDS:
        if kind == "oe":
            u, y = make.oe_plant(seed)
            m = oe(iddata(y, u, 1.0), 2, 2, 1)
            first = m.parameters.start_losses["instrumental variables"]
        else:
            u, y = make.armax_plant(seed)
            m = armax(iddata(y, u, 1.0), 2, 2, 1, 1)
            first = m.parameters.start_losses["pseudo-linear regression"]
        best = min(references[kind][seed], m.parameters.loss)
        found += m.parameters.loss <= best * (1 + SAME)
        single += first <= best * (1 + SAME)
    print(f"{kind}: global optimum in {found} of 100 seeds, from the first start alone in {single}")
    assert found >= 95, (found, single)
    assert single < found  # the case has local minima one start falls into
