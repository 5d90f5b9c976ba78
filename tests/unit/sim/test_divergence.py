"""The divergence check (elab/sim/engine.py) against its definition, row by row: the first
row holding a value that is not finite or beyond ±DIVERGENCE_LIMIT, on arrays with NaN,
±inf and large values planted anywhere (its fast path skips the search when min and max
are within the limit)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from elab.sim.engine import first_divergence
from elab.sim.spec import DIVERGENCE_LIMIT

L = DIVERGENCE_LIMIT


def by_definition(rows: np.ndarray) -> int | None:
    for i, row in enumerate(rows):
        if any(not math.isfinite(v) or abs(v) > L for v in row):
            return i
    return None


BAD = [math.nan, math.inf, -math.inf, L * (1 + 1e-15), -L * 1.5, 1e308]
GOOD = [L, -L, 0.0, -0.0, 1e-300, 123.0]


@given(
    n=st.integers(0, 40),
    m=st.integers(1, 6),
    planted=st.lists(
        st.tuples(st.integers(0, 39), st.integers(0, 5), st.sampled_from(BAD + GOOD)),
        max_size=6,
    ),
    strided=st.booleans(),
)
def test_the_first_diverged_row_is_found_as_defined(
    n: int, m: int, planted: list[tuple[int, int, float]], strided: bool
) -> None:
    rows = np.random.default_rng(n * 7 + m).uniform(-1e3, 1e3, (n, m + 1))
    for i, j, v in planted:
        if i < n and j < m:
            rows[i, j] = v
    view = rows[:, :m] if strided else np.ascontiguousarray(rows[:, :m])  # as the engine's
    assert first_divergence(view) == by_definition(view)


def test_the_limit_itself_is_within_and_nan_anywhere_is_not() -> None:
    assert first_divergence(np.array([[L, -L], [0.0, 1.0]])) is None
    assert first_divergence(np.array([[0.0, 1.0], [2.0, math.nan]])) == 1
    assert first_divergence(np.array([[0.0, -math.inf], [math.nan, 0.0]])) == 0
    assert first_divergence(np.zeros((0, 3))) is None
