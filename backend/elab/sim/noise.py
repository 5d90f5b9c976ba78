"""Seeded sensor noise that depends only on (seed, sample index).

Noise is drawn in aligned blocks of ``BLOCK`` samples, block ``j`` from its own
generator ``default_rng([seed, j])`` (NumPy's PCG64 via ``SeedSequence``), so a
run stepped in chunks of any size gets bit-identical noise, and the same seed
always gives the same run.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

BLOCK = 1024


def sensor_noise(
    seed: int,
    k0: int,
    n: int,
    std: NDArray[np.float64],
    out: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """White Gaussian noise for samples ``k0 .. k0+n-1``, shape ``(n, len(std))``
    (written into ``out`` where given)."""
    m = std.size
    out = np.empty((n, m)) if out is None else out
    first, last = k0 // BLOCK, (k0 + n - 1) // BLOCK if n else k0 // BLOCK - 1
    pos = 0
    for j in range(first, last + 1):
        block = _block(seed, j, m)
        lo = max(k0, j * BLOCK) - j * BLOCK
        hi = min(k0 + n, (j + 1) * BLOCK) - j * BLOCK
        np.multiply(block[lo:hi], std, out=out[pos : pos + hi - lo])
        pos += hi - lo
    return out


@lru_cache(maxsize=1024)  # ≤ 8 MiB per channel; a live run reuses its current block
def _block(seed: int, j: int, m: int) -> NDArray[np.float64]:
    block = np.random.default_rng([seed, j]).standard_normal((BLOCK, m))
    block.setflags(write=False)
    return block
