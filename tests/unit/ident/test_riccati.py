"""The filter Riccati equation of the subspace method's Kalman gain, solved by doubling
(``elab.ident.subspace.filter_dare``), against scipy's QZ solver: the same stabilising
solution on random systems of 1 to 10 states and 1 to 3 outputs (stable and unstable A,
a cross covariance S), and None — scipy then decides — where no stabilising solution
exists."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from elab.ident.subspace import filter_dare


def _system(seed: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    n, ny = int(rng.integers(1, 11)), int(rng.integers(1, 4))
    A = rng.standard_normal((n, n))
    A *= rng.uniform(0.3, 1.5) / max(np.abs(np.linalg.eigvals(A)))  # stable or not
    C = rng.standard_normal((ny, n))
    M = rng.standard_normal((n + ny, n + ny + 3))
    J = M @ M.T / (n + ny + 3)  # the covariance of [w; v]
    return A, C, J[:n, :n], J[n:, n:], J[:n, n:]


@pytest.mark.parametrize("seed", range(60))
def test_doubling_gives_scipys_stabilising_solution(seed: int) -> None:
    A, C, Q, R, S = _system(seed)
    want = scipy.linalg.solve_discrete_are(A.T, C.T, Q, R, s=S)
    got = filter_dare(A, C, Q, R, S)
    assert got is not None
    np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-10 * np.abs(want).max())
    K = (A @ got @ C.T + S) @ np.linalg.inv(C @ got @ C.T + R)
    assert np.max(np.abs(np.linalg.eigvals(A - K @ C))) < 1  # the predictor is stable


def test_without_a_stabilising_solution_it_says_none() -> None:
    """An unstable mode the output does not see (C = 0 on it): no filter stabilises it.
    scipy raises; the doubling does not converge and leaves the decision to scipy."""
    A = np.diag([1.2, 0.5])
    C = np.array([[0.0, 1.0]])
    Q, R, S = np.eye(2), np.eye(1), np.zeros((2, 1))
    with pytest.raises(np.linalg.LinAlgError):
        scipy.linalg.solve_discrete_are(A.T, C.T, Q, R, s=S)
    assert filter_dare(A, C, Q, R, S) is None
