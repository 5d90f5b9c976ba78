"""What the CLI's path computes with numpy and scipy.linalg instead of python-control and
scipy.signal (0.7 s and more of imports each) equals what those give: the transfer
functions the workflow reports (python-control's ``ss2tf``), its continuous models (which
python-control's ``c2d`` with a zero-order hold turns back into the identified discrete
ones), and subspace identification's FFT convolution (``scipy.signal.fftconvolve``). Data:
the hair dryer (one input, one output) and the DaISy CD player arm (two and two;
tests/reference/ident/)."""

from __future__ import annotations

from pathlib import Path

import control as ct
import numpy as np
import pytest
import scipy.fft
import scipy.signal
from numpy.testing import assert_allclose

from elab.ident import IdData, iddata
from elab.ident import workflow as wf
from elab.ident.input_matrices import convolved, fast_len
from elab.ident.models import observability

REFERENCE = Path(__file__).resolve().parents[2] / "reference" / "ident"


def record(name: str) -> IdData:
    raw = np.loadtxt(REFERENCE / name)
    if name == "dryer.dat":
        return iddata(raw[:, 1], raw[:, 0], 0.08)
    return iddata(raw[:, 2:], raw[:, :2], 1.0)  # the CD player arm: DaISy gives no Ts


@pytest.mark.parametrize(
    ("name", "models"),
    [
        ("dryer.dat", ("arx:2,2,3", "arx:4,4,3", "armax:2,2,2,3", "oe:2,2,3", "n4sid:4")),
        ("cd_player_arm.dat", ("arx:2,2,1", "arx:4,4,1", "n4sid:3")),
    ],
)
def test_reported_models_equal_python_control_s(name: str, models: tuple[str, ...]) -> None:
    plan = wf.Plan(models=tuple(wf.parse_model(m) for m in models))
    result = wf.run(record(name), plan)
    for shown in result.models:
        m = shown.model
        tf = m.to_tf()  # python-control's ss2tf
        ours = m.transfer_functions()
        for i in range(m.ny):
            for j in range(m.nu):
                num, den = ours[i][j]
                # the same arithmetic (scipy.signal.ss2tf's): equal to rounding, same lengths
                assert_allclose(num, np.ravel(tf.num[i][j]), rtol=1e-12, atol=1e-12)
                assert_allclose(den, np.ravel(tf.den[i][j]), rtol=1e-12, atol=1e-12)
        c = shown.continuous
        if c is None:  # a pole at z = 0 (a delay) or on the negative real axis: no logarithm
            assert m.kind != "n4sid"  # these subspace models have neither
            continue
        back = ct.c2d(ct.ss(c.A, c.B, c.C, c.D), m.Ts, "zoh")
        # expm(logm(M)) = M to rounding; the entries are of order 1
        assert_allclose(back.A, m.A, atol=1e-12)
        assert_allclose(back.B, m.B, atol=1e-12)
        assert np.array_equal(back.C, m.C) and np.array_equal(back.D, m.D)


def test_fft_lengths_are_scipy_s() -> None:
    assert [fast_len(n) for n in range(1, 30_001)] == [
        scipy.fft.next_fast_len(n, real=True) for n in range(1, 30_001)
    ]


@pytest.mark.parametrize(("N", "ny", "nu"), [(500, 1, 1), (1023, 2, 2), (97, 3, 1)])
def test_the_fft_simulation_is_fftconvolve_s(N: int, ny: int, nu: int) -> None:
    rng = np.random.default_rng(N)
    n = 4
    A = rng.standard_normal((n, n))
    A *= 0.95 / np.max(np.abs(np.linalg.eigvals(A)))  # stable
    B, C = rng.standard_normal((n, nu)), rng.standard_normal((ny, n))
    D, x0, u = rng.standard_normal((ny, nu)), rng.standard_normal(n), rng.standard_normal((N, nu))
    y = convolved(A, B, C, D, x0, u)
    # the former code: y(t) = C Aᵗ x₀ + D u(t) + Σ_k (C A^{t−1−j} b_k) * u_k(j), j < t
    h = observability(A, C, N)  # C Aᵗ, (N, ny, n)
    want = h @ x0 + u @ D.T
    for k in range(nu):
        want[1:] += scipy.signal.fftconvolve(h @ B[:, k], u[:, [k]], axes=0)[: N - 1]
    assert_allclose(y, want, rtol=1e-12, atol=1e-12)  # the same pocketfft: equal to rounding
