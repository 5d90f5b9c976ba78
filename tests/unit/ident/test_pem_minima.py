"""OE and ARMAX on a plant whose prediction-error loss has several minima: two resonances
(at 0.5 and 2.0 rad/sample, |z| = 0.95) seen through a second-order model, which can
follow either one. Issue 16: the estimate must be the global optimum — found here by an
independent brute-force reference (Gauss–Newton from many random stable starts) — in at
least 95 of 100 seeds. Measured: both find it in 100 of 100; from the one start each
had before (instrumental variables for OE, pseudo-linear regression for ARMAX) they
found it in 2 and 77."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import scipy.signal

from elab.ident import iddata
from elab.ident.pem import C_RADIUS, _gauss_newton, _reflect, armax, oe
from elab.ident.polynomial import regressors

N = 800
SEEDS = range(100)
RANDOM_STARTS = 8
SAME = 1e-3  # relative loss within which two minima are the same one


def _plant(seed: int, second: float, noise: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """The resonance at 2.0 rad/sample has ``second`` times the first one's gain."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    y = np.zeros(N)
    for w, gain in ((0.5, 1.0), (2.0, second)):
        p = 0.95 * np.exp(1j * w)
        y += gain * scipy.signal.lfilter([0, 0.05], np.real(np.poly([p, np.conj(p)])), u)
    e = 0.5 * np.std(y) * rng.standard_normal(N)
    return u, y + scipy.signal.lfilter(noise, [1.0], e)


def _random_monic(rng: np.random.Generator, n: int) -> np.ndarray:
    """A stable monic polynomial of degree n: a pair at a random angle, or a real root."""
    if n == 2 and rng.random() < 0.7:
        p = rng.uniform(0.3, 0.98) * np.exp(1j * rng.uniform(0.0, np.pi))
        return np.real(np.poly([p, np.conj(p)]))
    return np.real(np.poly(rng.uniform(-0.95, 0.95, n)))


def _brute_force(
    residuals: Callable[[np.ndarray], np.ndarray],
    gradient: Callable[[np.ndarray, np.ndarray], np.ndarray],
    stabilise: Callable[[np.ndarray], np.ndarray],
    starts: list[np.ndarray],
) -> float:
    best = np.inf
    for theta in starts:
        _, eps, _ = _gauss_newton(stabilise(theta), residuals, gradient, stabilise, 200, 1e-10)
        best = min(best, float(eps @ eps / eps.shape[0]))
    return best


def _oe_reference(u: np.ndarray, y: np.ndarray, seed: int) -> float:
    nb, nf, nk = 2, 2, 1

    def simulate(th: np.ndarray) -> np.ndarray:
        return scipy.signal.lfilter(np.r_[np.zeros(nk), th[nf:]], np.r_[1.0, th[:nf]], u)

    def gradient(th: np.ndarray, eps: np.ndarray) -> np.ndarray:
        yhat = np.r_[np.zeros(nf), y - eps]
        cols = [-yhat[nf - i : nf + N - i] for i in range(1, nf + 1)]
        upad = np.r_[np.zeros(nk + nb), u]
        cols += [upad[nb - j : nb - j + N] for j in range(nb)]
        return scipy.signal.lfilter([1.0], np.r_[1.0, th[:nf]], np.column_stack(cols), axis=0)

    rng = np.random.default_rng(10_000 + seed)
    starts = [
        np.r_[_random_monic(rng, nf)[1:], rng.normal(0, 0.1, nb)] for _ in range(RANDOM_STARTS)
    ]
    return _brute_force(
        lambda th: y - simulate(th),
        gradient,
        lambda th: np.r_[_reflect(np.r_[1.0, th[:nf]])[1:], th[nf:]],
        starts,
    )


def _armax_reference(u: np.ndarray, y: np.ndarray, seed: int) -> float:
    na, nb, nc, nk = 2, 2, 1, 1
    Phi, Y = regressors(y, u, na, nb, nk, max(na, nb + nk - 1))

    def residuals(th: np.ndarray) -> np.ndarray:
        return scipy.signal.lfilter([1.0], np.r_[1.0, th[na + nb :]], Y - Phi @ th[: na + nb])

    def gradient(th: np.ndarray, eps: np.ndarray) -> np.ndarray:
        lags = np.column_stack(
            [np.r_[np.zeros(k), eps[: eps.shape[0] - k]] for k in range(1, nc + 1)]
        )
        return scipy.signal.lfilter(
            [1.0], np.r_[1.0, th[na + nb :]], np.column_stack([Phi, lags]), axis=0
        )

    rng = np.random.default_rng(20_000 + seed)
    starts = [
        np.r_[_random_monic(rng, na)[1:], rng.normal(0, 0.1, nb), rng.uniform(-0.9, 0.9, nc)]
        for _ in range(RANDOM_STARTS)
    ]
    return _brute_force(
        residuals,
        gradient,
        lambda th: np.r_[th[: na + nb], _reflect(np.r_[1.0, th[na + nb :]], C_RADIUS)[1:]],
        starts,
    )


@pytest.mark.parametrize("kind", ["oe", "armax"])
def test_the_global_optimum_is_found_in_95_of_100_seeds(kind: str) -> None:
    found, single = 0, 0
    for seed in SEEDS:
        if kind == "oe":
            u, y = _plant(seed, 1.4, [1.0])
            m = oe(iddata(y, u, 1.0), 2, 2, 1)
            reference = _oe_reference(u, y, seed)
            first = m.parameters["start_losses"]["instrumental variables"]
        else:
            u, y = _plant(seed, 1.0, [1.0, 0.5])
            m = armax(iddata(y, u, 1.0), 2, 2, 1, 1)
            reference = _armax_reference(u, y, seed)
            first = m.parameters["start_losses"]["pseudo-linear regression"]
        best = min(reference, m.parameters["loss"])
        found += m.parameters["loss"] <= best * (1 + SAME)
        single += first <= best * (1 + SAME)
    print(f"{kind}: global optimum in {found} of 100 seeds, from the first start alone in {single}")
    assert found >= 95, (found, single)
    assert single < found  # the case has local minima one start falls into
