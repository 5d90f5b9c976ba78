"""Linear time-invariant systems in state space, :math:`x' = A x + B u,\\ y = C x + D u`:
the sizes every such system of the lab knows (a plant, a model to design on, an
identified model), and the two discretisations the stepping loop needs.

:func:`zoh` and :func:`tustin` are scipy's ``cont2discrete`` (which python-control's
``c2d`` calls) for those two methods, operation for operation: a run is compiled without
importing python-control, which brings matplotlib and scipy.signal (a second of imports
for ``elab simulate``, issue 28). ``tests/unit/sim/test_discretise.py`` holds them to
python-control's ``c2d``, bit for bit."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


class StateSpaceShape:
    """The sizes of a system's ``A`` (nx × nx), ``B`` (nx × nu) and ``C`` (ny × nx): ``nx``
    states, ``nu`` inputs, ``ny`` outputs."""

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]

    @property
    def nx(self) -> int:
        return int(self.A.shape[0])

    @property
    def nu(self) -> int:
        return int(self.B.shape[1])

    @property
    def ny(self) -> int:
        return int(self.C.shape[0])


def zoh(
    A: NDArray[np.float64], B: NDArray[np.float64], Ts: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A and B of the zero-order-hold equivalent at sample time ``Ts``: the top rows of
    exp(Ts [[A, B], [0, 0]]) (C and D stay)."""
    import scipy.linalg  # here: the web process imports this module, not scipy

    n, m = A.shape[0], B.shape[1]
    em = np.vstack((np.hstack((A, B)), np.hstack((np.zeros((m, n)), np.zeros((m, m))))))
    ms = scipy.linalg.expm(Ts * em)[:n, :]
    return np.asarray(ms[:, :n], dtype=np.float64), np.asarray(ms[:, n:], dtype=np.float64)


def tustin(
    A: NDArray[np.float64],
    B: NDArray[np.float64],
    C: NDArray[np.float64],
    D: NDArray[np.float64],
    Ts: float,
) -> tuple[NDArray[np.float64], ...]:
    """A, B, C and D of the bilinear (Tustin) equivalent at sample time ``Ts``, without
    prewarping: s = (2 / Ts) (z − 1) / (z + 1)."""
    import scipy.linalg

    alpha = 0.5
    ima = np.eye(A.shape[0]) - alpha * Ts * A
    Ad = scipy.linalg.solve(ima, np.eye(A.shape[0]) + (1.0 - alpha) * Ts * A)
    Bd = scipy.linalg.solve(ima, Ts * B)
    Cd = scipy.linalg.solve(ima.transpose(), C.transpose()).transpose()
    Dd = D + alpha * np.dot(C, Bd)
    return tuple(np.asarray(M, dtype=np.float64) for M in (Ad, Bd, Cd, Dd))
