"""B and D (and the initial state x₀) of a state-space model whose A and C are known, the
last step of subspace identification (:mod:`elab.ident.subspace`): from the R factor of
the block Hankel matrices as SLICOT computes them for N4SID, or by the least squares fit
of the simulated output; and the fast simulation both use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from elab.ident.data import IdData
from elab.ident.models import observability

if TYPE_CHECKING:
    from elab.ident.subspace import Subspace

Array = NDArray[np.float64]


def subspace_bd(sub: Subspace, A: Array, C: Array) -> tuple[Array, Array]:
    """B and D from the R factor as SLICOT's IB01PD/IB01PX compute them for METH = 'N'
    (N4SID's robust algorithm: Van Overschee & De Moor 1996, sec. 4.3.3; Sima 1996), the
    routine GNU Octave's ``n4sid`` runs.

    With Γ = U₁ (the orthonormal singular vectors: SLICOT's basis), Z_i = Y_f / [W_p; U_f]
    and Z_{i+1} = Y_f⁻ / [W_p⁺; U_f⁻] (orthogonal projections; the minus drops the first
    block row, the plus adds it to the past), Γ_s⁺ Z_i = X̂_i + Γ_s⁺ H_s U_f and
    Γ_{s−1}⁺ Z_{i+1} = X̂_{i+1} + Γ_{s−1}⁺ H_{s−1} U_f⁻, so

        [Γ_{s−1}⁺ Z_{i+1}; Y_{i|i}] − [A; C] Γ_s⁺ Z_i = 𝒦(B, D) U_f + residuals,
        𝒦 = [[B, Γ_{s−1}⁺ H_{s−1}] − A Γ_s⁺ H_s;  [D, 0] − C Γ_s⁺ H_s],

    linear in B and D. H_s is the block Toeplitz matrix of the Markov parameters D,
    Γ₁ B, Γ₂ B, … — SLICOT takes them from the estimated Γ's block rows Γ_k (≈ C A^{k−1}),
    not from powers of the estimated A: with noise the two differ, and the powers of A
    fitted heating_system's validation record 30–140 points worse at orders 7–10. Every
    signal lies in the row space of the Hankel matrix, so the least squares runs on its
    coordinates in Q (the rows of L; only the U_f columns carry 𝒦), with the rank
    tolerance of SLICOT's DGELSY. B is returned in this module's basis (Γ = U₁ Σ₁^½)."""
    import scipy.linalg  # here: the web process imports this module, not scipy

    data, s = sub.data, sub.horizon
    nu, ny, n = data.nu, data.ny, A.shape[0]
    L = sub.L
    a, b = s * nu, s * (nu + ny) + s * nu  # U_f | W_p | Y_f
    root = np.sqrt(sub.singular_values[:n])
    A, C = A * root[:, None] / root[None, :], C / root[None, :]  # into SLICOT's basis
    G = sub.U1[:, :n]
    Yf = L[b:, :a]  # only the U_f columns of Z_i, Z_{i+1} and Y_{i|i} matter
    Gi = np.asarray(np.linalg.pinv(G[:-ny]), dtype=np.float64)  # Γ_{s−1}⁺, for both uses
    P = np.vstack([Gi @ Yf[ny:], Yf[:ny]]) - np.vstack([A, C]) @ (G.T @ Yf)
    blocks = G[:-ny].reshape(s - 1, ny, n)  # Γ_k, k = 1 … s−1
    T = _bd_regressors(G, Gi, A, C, blocks, L[:a, :a], nu)
    tol = T.shape[0] * T.shape[1] * np.finfo(float).eps  # DGELSY's, as IB01PX sets it
    theta = np.asarray(
        scipy.linalg.lstsq(T, P.ravel(), cond=tol, lapack_driver="gelsy", check_finite=False)[0],
        dtype=np.float64,
    )
    D = theta[: ny * nu].reshape(ny, nu)
    B = theta[ny * nu :].reshape(n, nu) / root[:, None]
    return B, D


def _bd_regressors(
    G: Array, Gi: Array, A: Array, C: Array, blocks: Array, Uf: Array, nu: int
) -> Array:
    """The columns of 𝒦(B, D) U_f (flattened), one per unknown of θ = [vec D; vec B]
    (𝒦 is linear in θ: all unit θ at once, as a batch); ``Gi``: Γ_{s−1}⁺."""
    sny, n = G.shape
    ny = C.shape[0]
    s = sny // ny
    d = ny * nu + n * nu
    unit = np.eye(d)
    D, B = unit[:, : ny * nu].reshape(d, ny, nu), unit[:, ny * nu :].reshape(d, n, nu)
    markov = np.concatenate([D[:, None], blocks @ B[:, None]], axis=1)  # D, Γ₁B, …
    lag = np.subtract.outer(np.arange(s), np.arange(s))  # r − c of block (r, c)
    H = markov[:, np.clip(lag, 0, s - 1)] * (lag >= 0)[None, :, :, None, None]
    H = H.transpose(0, 1, 3, 2, 4).reshape(d, sny, s * nu)  # block (r, c) = M_{r−c}
    GH = G.T @ H  # Γ_s⁺ H_s (Γ orthonormal)
    top, bottom = -A @ GH, -C @ GH
    top[:, :, :nu] += B
    top[:, :, nu:] += Gi @ H[:, ny:, nu:]
    bottom[:, :, :nu] += D
    return np.asarray((np.concatenate([top, bottom], axis=1) @ Uf).reshape(d, -1).T)


def simulation_bd(data: IdData, A: Array, C: Array) -> tuple[Array, Array, Array]:
    """B, D and x₀ minimising ‖y − ŷ‖² of the simulated output, a linear least squares in
    them: y(t) = C Aᵗ x₀ + Σ_{k<t} C A^{t−1−k} B u(k) + D u(t)."""
    import scipy.linalg  # here: the web process imports this module, not scipy

    N, nu, ny, n = data.N, data.nu, data.ny, A.shape[0]
    free, forced = fft_regressors(A, C, data.u)
    cols: list[Array] = [free.reshape(N * ny, n)]  # x₀
    cols += [f.reshape(N * ny, n) for f in forced]  # B, input by input
    for k in range(nu):  # D: u_k appears in output i
        cols.append(np.asarray(np.kron(data.u[:, k][:, None], np.eye(ny)), dtype=np.float64))
    M = np.hstack(cols)
    theta = np.asarray(
        scipy.linalg.lstsq(M, data.y.reshape(-1), lapack_driver="gelsy", check_finite=False)[0],
        dtype=np.float64,
    )
    x0 = theta[:n]
    B = theta[n : n + n * nu].reshape(nu, n).T
    D = theta[n + n * nu :].reshape(nu, ny).T
    return B, D, x0


def fft_regressors(A: Array, C: Array, u: Array) -> tuple[Array, list[Array]]:
    """C Aᵗ (N, ny, n), and per input k the Markov parameters convolved with u_k one step
    late, Σ_{j<t} C A^{t−1−j} u_k(j), by FFT."""
    N, ny, n = u.shape[0], C.shape[0], A.shape[0]
    h = observability(A, C, N)
    L = fast_len(2 * N - 1)
    H = np.fft.rfft(h.reshape(N, ny * n), L, axis=0)
    forced = []
    for k in range(u.shape[1]):
        Uk = np.fft.rfft(np.r_[0.0, u[:-1, k]], L)
        forced.append(np.fft.irfft(H * Uk[:, None], L, axis=0)[:N].reshape(N, ny, n))
    return h, forced


def fast_len(n: int) -> int:
    """The least 2ᵃ 3ᵇ 5ᶜ ≥ ``n``: a length the FFT transforms fast, as
    ``scipy.fft.next_fast_len(n, real=True)`` (numpy's FFT is the same pocketfft, and
    scipy.fft costs 65 ms of imports through scipy.special)."""
    best = 1 << max(n - 1, 0).bit_length()  # the power of 2
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            p = p35
            while p < n:
                p *= 2
            best = min(best, p)
            p35 *= 3
        p5 *= 5
    return best


def simulate(
    A: Array, B: Array, C: Array, D: Array, x0: Array, u: Array, h: Array | None = None
) -> Array:
    """The simulated output (an unstable model's may overflow to inf or nan); ``h``: C Aᵗ
    for t < N where the caller has it (:func:`~elab.ident.models.observability`)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return convolved(A, B, C, D, x0, u, h)


def convolved(
    A: Array, B: Array, C: Array, D: Array, x0: Array, u: Array, h: Array | None = None
) -> Array:
    N = u.shape[0]
    h = observability(A, C, N) if h is None else h
    y = h @ x0 + u @ D.T
    L = fast_len(2 * N - 1)  # as scipy.signal.fftconvolve pads
    for k in range(u.shape[1]):
        hb = h @ B[:, k]  # (N, ny) impulse response C A^t b_k
        Uk = np.fft.rfft(u[:, k], L)
        conv = np.fft.irfft(np.fft.rfft(hb, L, axis=0) * Uk[:, None], L, axis=0)[:N]
        y[1:] += conv[:-1]
    return np.asarray(y, dtype=np.float64)
