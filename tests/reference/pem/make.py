"""Reference computations of the prediction-error tests, made once and committed
(``pem.json`` beside this script): they take a minute, and the tests that use them check
a few of them afresh on every run (tests/unit/ident/test_pem.py, test_pem_minima.py).

Run ``.venv/bin/python -m tests.reference.pem.make`` after a change to ``elab.ident.pem``
or to the data below; it rewrites ``pem.json``.

- ``minima``: for 100 seeds of a plant whose prediction-error loss has several minima
  (two resonances, at 0.5 and 2.0 rad/sample with |z| = 0.95, seen through a second-order
  model), the best loss of an independent brute-force search — Gauss–Newton from 8 random
  stable starts — for OE(2, 2, 1) and ARMAX(2, 2, 1, 1).
- ``armax_c``: the C polynomial E-Lab's ``armax`` estimates for the known ARMAX system of
  ``test_pem.py`` over 30 seeds (N = 5000, λ = 0.1), for the bias check.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy.signal

from elab.ident import IdData, iddata
from elab.ident.pem import C_RADIUS, _gauss_newton, _reflect, armax
from elab.ident.polynomial import regressors

OUT = Path(__file__).with_name("pem.json")

# the multi-minimum plant (test_pem_minima.py)
N = 800
SEEDS = range(100)
RANDOM_STARTS = 8

# the known ARMAX system (test_pem.py)
A, B, C = np.array([1, -1.5, 0.7]), np.array([0, 1, 0.5]), np.array([1, -0.5, 0.2])
ARMAX_SEEDS = range(30)


def armax_data(seed: int, c: np.ndarray = C, N: int = 5000, lam: float = 0.1) -> IdData:
    """y = B/A u + C/A e for the known system, white u and e (variance ``lam``)."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    e = np.sqrt(lam) * rng.standard_normal(N)
    y = scipy.signal.lfilter(B, A, u) + scipy.signal.lfilter(c, A, e)
    return iddata(y, u, 1.0)


def armax_c(seed: int) -> list[float]:
    """C's coefficients after the leading 1 as E-Lab's armax(2, 2, 2, 1) estimates them."""
    return [float(x) for x in armax(armax_data(seed), 2, 2, 2, 1).parameters.C[1:]]


def plant(seed: int, second: float, noise: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """The resonance at 2.0 rad/sample has ``second`` times the first one's gain."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    y = np.zeros(N)
    for w, gain in ((0.5, 1.0), (2.0, second)):
        p = 0.95 * np.exp(1j * w)
        y += gain * scipy.signal.lfilter([0, 0.05], np.real(np.poly([p, np.conj(p)])), u)
    e = 0.5 * np.std(y) * rng.standard_normal(N)
    return u, y + scipy.signal.lfilter(noise, [1.0], e)


def oe_plant(seed: int) -> tuple[np.ndarray, np.ndarray]:
    return plant(seed, 1.4, [1.0])


def armax_plant(seed: int) -> tuple[np.ndarray, np.ndarray]:
    return plant(seed, 1.0, [1.0, 0.5])


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


def oe_reference(seed: int) -> float:
    """The brute-force OE(2, 2, 1) optimum's loss on ``oe_plant(seed)``."""
    u, y = oe_plant(seed)
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


def armax_reference(seed: int) -> float:
    """The brute-force ARMAX(2, 2, 1, 1) optimum's loss on ``armax_plant(seed)``."""
    u, y = armax_plant(seed)
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


def load() -> dict[str, object]:
    return json.loads(OUT.read_text())  # type: ignore[no-any-return]


def main() -> int:
    made = {
        "minima": {
            "oe": [oe_reference(s) for s in SEEDS],
            "armax": [armax_reference(s) for s in SEEDS],
        },
        "armax_c": [armax_c(s) for s in ARMAX_SEEDS],
    }
    OUT.write_text(json.dumps(made, indent=1) + "\n")
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
