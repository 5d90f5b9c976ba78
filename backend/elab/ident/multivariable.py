"""ARX models with several inputs and outputs, as GNU Octave's ``arx`` estimates them: one
multi-input single-output least-squares problem per output (Ljung 1999, sec. 4.2). Output
i obeys

    A_i(q) y_i(t) = Σ_j B_ij(q) u_j(t − nk_ij) + e_i(t),
    A_i(q) = 1 + a_i,1 q⁻¹ + … + a_i,na_i q^−na_i,   B_ij(q) = b_ij,1 + … + b_ij,nb_ij q^(1−nb_ij),

so y = A⁻¹(q) B(q) u + A⁻¹(q) e with A(q) = diag(A_1 … A_ny): no output's past enters
another output's equation (MATLAB's ``arx`` also takes an ny × ny ``na`` that couples them;
Octave's does not, nor does this). Each θ_i minimises Σ ε_i(t)² over the samples whose
regressors lie inside the data, t ≥ n_i = max(na_i, max_j (nb_ij + nk_ij − 1)), as for one
output. Orders: ``na`` an integer or one per output; ``nb`` and ``nk`` an integer or an
ny × nu matrix (output × input); nb_ij = 0 leaves input j out of output i's equation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elab.errors import InvalidInput
from elab.ident.data import IdData, require_exciting
from elab.ident.models import LinearModel
from elab.ident.parameters import ArxOrders, Ints, MimoArxParameters

Array = NDArray[np.float64]
#: an order: one integer for every channel, or one per output (na) or per output and input
Orders = int | Sequence[int] | Sequence[Sequence[int]] | NDArray[np.integer[Any]]


def arx_orders(na: Orders, nb: Orders, nk: Orders, ny: int, nu: int) -> ArxOrders:
    """The orders as arrays of their full shape; raise naming the first bad one."""
    size = f"a {ny} × {nu} matrix of them (output × input)"
    o = ArxOrders(
        _integers("na", na, (ny,), f"an integer ≥ 0, or {ny} of them (one per output)"),
        _integers("nb", nb, (ny, nu), f"an integer ≥ 0, or {size}"),
        _integers("nk", nk, (ny, nu), f"an integer ≥ 0, or {size}"),
    )
    empty = np.flatnonzero(o.na + o.nb.sum(axis=1) == 0)
    if empty.size:
        i = int(empty[0])
        raise InvalidInput(
            f"nb[{i}]", o.nb[i].tolist(), f"na + Σ nb ≥ 1 for every output (row {i}: none)"
        )
    return o


def _integers(name: str, value: Orders, shape: tuple[int, ...], allowed: str) -> Ints:
    try:
        a = np.asarray(value)
    except ValueError:  # a ragged list
        raise InvalidInput(name, value, allowed) from None
    if (
        a.dtype.kind not in "iu"
        or (a.ndim and a.squeeze().shape != _squeezed(shape))
        or np.any(a < 0)
    ):
        raise InvalidInput(name, value, allowed)
    full = np.broadcast_to(a, shape) if a.ndim == 0 else a.reshape(shape)
    return full.astype(np.int64)


def _squeezed(shape: tuple[int, ...]) -> tuple[int, ...]:
    return tuple(d for d in shape if d != 1)


def miso_regressors(
    y: Array, U: Array, na: int, nb: Sequence[int], nk: Sequence[int], start: int
) -> tuple[Array, Array]:
    """Φ (rows φ(t)ᵀ = [−y(t−1) … −y(t−na), u_1(t−nk_1) … u_1(t−nk_1−nb_1+1), u_2 …] for
    t = start … N−1) and Y = y(start …); ``U`` is (N, nu)."""
    N = y.shape[0]
    cols = [-y[start - i : N - i] for i in range(1, na + 1)]
    for j in range(U.shape[1]):
        cols += [U[start - nk[j] - k : N - nk[j] - k, j] for k in range(nb[j])]
    return np.column_stack(cols) if cols else np.zeros((N - start, 0)), y[start:]


@dataclass(frozen=True)
class _OutputFit:
    a: Array
    b: list[Array]
    da: Array
    db: list[Array]
    eps: Array
    start: int
    lam: float
    d: int


def arx_per_output(data: IdData, na: Orders, nb: Orders, nk: Orders) -> LinearModel:
    """The least-squares ARX model of several inputs and outputs (module docstring), as one
    innovations state space (:func:`from_polynomial_rows`).

    ``parameters`` (:class:`~elab.ident.parameters.MimoArxParameters`): ``A`` per output;
    ``B`` per output and input, each with its nk_ij leading zeros; ``dA``, ``dB`` their
    standard deviations; ``loss``, ``fpe``, ``aic``, ``samples`` per output. The noise
    covariance Λ has each output's residual variance Σ ε_i² / (samples − parameters) on
    its diagonal and the residuals' correlations over their common samples off it.
    """
    o = arx_orders(na, nb, nk, data.ny, data.nu)
    for j in range(data.nu):
        require_exciting(data.u[:, [j]], int(o.nb[:, j].max()), f"u[{j}]")
    fits = [_fit_output(data, o, i) for i in range(data.ny)]
    m = from_polynomial_rows([f.a for f in fits], [f.b for f in fits], data.Ts, _noise(fits))
    stats = [_stats(f) for f in fits]
    return replace(
        m,
        parameters=MimoArxParameters(
            orders=o,
            A=tuple(f.a for f in fits),
            B=tuple(tuple(f.b) for f in fits),
            dA=tuple(f.da for f in fits),
            dB=tuple(tuple(f.db) for f in fits),
            loss=tuple(s.loss for s in stats),
            fpe=tuple(s.fpe for s in stats),
            aic=tuple(s.aic for s in stats),
            samples=tuple(s.samples for s in stats),
        ),
    )


def _fit_output(data: IdData, o: ArxOrders, i: int) -> _OutputFit:
    start, na, nb, nk = int(o.n[i]), int(o.na[i]), o.nb[i], o.nk[i]
    d = na + int(nb.sum())
    if data.N - start <= d:
        raise InvalidInput(
            "data",
            f"{data.N} samples",
            f"more than {start + d} samples for output {data.output_names[i]} "
            f"({d} parameters from sample {start} on)",
        )
    Phi, Y = miso_regressors(data.y[:, i], data.u, na, nb.tolist(), nk.tolist(), start)
    theta, *_ = np.linalg.lstsq(Phi, Y, rcond=None)
    eps = Y - Phi @ theta
    lam = float(eps @ eps / (Y.shape[0] - d))
    try:
        sd = np.sqrt(np.clip(np.diag(lam * np.linalg.inv(Phi.T @ Phi)), 0, None))
    except np.linalg.LinAlgError:
        sd = np.full(d, np.nan)
    cut = na + np.r_[0, np.cumsum(nb)]
    return _OutputFit(
        a=np.r_[1.0, theta[:na]],
        b=[np.r_[np.zeros(nk[j]), theta[cut[j] : cut[j + 1]]] for j in range(data.nu)],
        da=np.r_[0.0, sd[:na]],
        db=[np.r_[np.zeros(nk[j]), sd[cut[j] : cut[j + 1]]] for j in range(data.nu)],
        eps=eps,
        start=start,
        lam=lam,
        d=d,
    )


@dataclass(frozen=True)
class _Stats:
    loss: float
    fpe: float
    aic: float
    samples: int


def _stats(f: _OutputFit) -> _Stats:
    n = f.eps.shape[0]
    loss = float(f.eps @ f.eps / n)
    return _Stats(
        loss=loss,
        fpe=loss * (1 + f.d / n) / (1 - f.d / n),
        aic=math.log(loss) + 2 * f.d / n if loss > 0 else -math.inf,
        samples=n,
    )


def _noise(fits: list[_OutputFit]) -> Array:
    first = max(f.start for f in fits)  # samples every output's residual covers
    E = np.column_stack([f.eps[first - f.start :] for f in fits])
    norm = np.sqrt(np.sum(E**2, axis=0))
    scale = np.divide(1.0, norm, out=np.zeros_like(norm), where=norm > 0)
    R = scale[:, None] * (E.T @ E) * scale[None, :]
    np.fill_diagonal(R, 1.0)
    s = np.sqrt([f.lam for f in fits])
    return np.asarray(R * np.outer(s, s), dtype=np.float64)


def from_polynomial_rows(
    A: Sequence[Array], B: Sequence[Sequence[Array]], Ts: float, lam: Array
) -> LinearModel:
    """A_i(q) y_i = Σ_j B_ij(q) u_j + e_i (a_i,0 = 1) as one innovations state space: each
    output's observer form (n_i = max(deg A_i, deg B_ij) states; x_i,1 = y_i − e_i − D_i u,
    K_i = −[a_i,1 … a_i,n_i]ᵀ), the outputs' blocks on the diagonal."""
    import scipy.linalg  # here: the web process imports this module, not scipy

    blocks = [_observer(a, b) for a, b in zip(A, B, strict=True)]
    return LinearModel(
        scipy.linalg.block_diag(*(blk[0] for blk in blocks)),
        np.vstack([blk[1] for blk in blocks]),
        scipy.linalg.block_diag(*(blk[2] for blk in blocks)),
        np.vstack([blk[3] for blk in blocks]),
        scipy.linalg.block_diag(*(blk[4] for blk in blocks)),
        Ts,
        lam,
    )


def _observer(a: Array, b: Sequence[Array]) -> tuple[Array, Array, Array, Array, Array]:
    n = max(len(a), *(len(p) for p in b)) - 1
    a = np.r_[a, np.zeros(n + 1 - len(a))]
    b = [np.r_[p, np.zeros(n + 1 - len(p))] for p in b]
    F = np.zeros((n, n))
    H = np.zeros((1, n))
    if n:
        F[:, 0] = -a[1:]
        F[:-1, 1:] = np.eye(n - 1)
        H[0, 0] = 1.0
    G = np.column_stack([p[1:] - a[1:] * p[0] for p in b]).reshape(n, len(b))
    D = np.array([[p[0] for p in b]])
    return F, G, H, D, -a[1:].reshape(n, 1)
