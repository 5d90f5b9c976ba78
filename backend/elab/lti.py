"""Linear time-invariant systems in state space, :math:`x' = A x + B u,\\ y = C x + D u`:
the sizes every such system of the lab knows (a plant, a model to design on, an
identified model)."""

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
