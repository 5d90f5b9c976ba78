"""The hair-dryer data (tests/reference/ident/, a copy of the team's reference) as
MATLAB's standard experiment: estimation = samples 1…500, validation = 501…1000, each
detrended by its own mean."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from elab.ident import IdData, iddata

DRYER = Path(__file__).resolve().parents[2] / "reference" / "ident" / "dryer.dat"


@pytest.fixture(scope="module")
def dryer() -> tuple[IdData, IdData]:
    raw = np.loadtxt(DRYER)
    z = iddata(raw[:, 1], raw[:, 0], 0.08)
    return z[:500].detrend(), z[500:].detrend()
