"""Issue 26: E-Lab's ``n4sid`` fits every public data set at every order 1 … 10 at least
as well as SLICOT's (GNU Octave's control package 3.4.0: IB01AD, IB01BD with METH = 'N',
IB01CD), at the same estimation/validation split, detrend and horizon (s = 20), from a
zero and from the estimated initial state, output by output. The sets, their columns and
splits: public_sets.py and tests/reference/ident/public_sets.md; the table:
scripts/subspace_vs_slicot.py."""

from __future__ import annotations

import pytest

from tests.unit.ident.public_sets import ORDERS, SETS, Cell, cells, octave, run_slicot

pytestmark = pytest.mark.skipif(
    octave() is None,
    reason="GNU Octave is not installed (make test installs octave and octave-control)",
)
TOLERANCE = 1.0  # points of fit %: the bound


@pytest.fixture(scope="module")
def table() -> dict[tuple[str, int], Cell]:
    return {(c.name, c.order): c for c in cells(run_slicot())}  # one Octave run, all cells


def test_there_are_eight_sets_or_more_at_every_order() -> None:
    assert len(SETS) >= 8
    assert range(1, 11) == ORDERS


@pytest.mark.parametrize("name", [s.name for s in SETS])
def test_no_order_fits_more_than_a_point_below_slicot(
    table: dict[tuple[str, int], Cell], name: str
) -> None:
    """(Before B and D followed IB01PX — Markov parameters from Γ's block rows, not from
    powers of A — 39 of these 130 cells were more than a point below; heating_system's
    orders 7 … 10 by 40 to 140 points.)"""
    below = {n: round(table[(name, n)].shortfall, 2) for n in ORDERS}
    assert all(v <= TOLERANCE for v in below.values()), below
