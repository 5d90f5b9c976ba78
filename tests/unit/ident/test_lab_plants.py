"""The lab's own plants, noise-free, as its runs record them (at the plant's sample time,
from rest, with a PRBS at the input; in closed loop with the predefined controller, and
in open loop where the plant does not diverge): an ARX model of the plant's own order
fits the validation part of the same record — simulated from its fitted initial state,
as the headline does for integrating plants — to 99.9 % or better.

Before the fitted state was computed on the modes: the flexible link at 1 kHz over
30 s of validation, a model that simulated its estimation data at 99.9991 % "fitted"
−39 % from its fitted state and −2,000 % on data it had simulated itself (powers of the
ARX companion matrix by repeated squaring lost the free response to round-off)."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from elab.ident import iddata
from elab.ident.polynomial import arx
from elab.ident.validation import compare
from elab.laws import StateFeedback
from elab.plants import get_plant


def record(pid: str, seconds: float, closed: bool) -> tuple[np.ndarray, np.ndarray, int, float]:
    """(u, first output, the order of u → y, Ts) of a noise-free run from rest."""
    p = get_plant(pid)
    A, B, C = (np.asarray(m, dtype=float) for m in (p.A, p.B, p.C))
    d = ct.c2d(ct.ss(A, B, C, np.zeros((C.shape[0], 1))), p.Ts)
    K = np.atleast_2d(p.predefined.K) if closed else np.zeros((1, A.shape[0]))
    assert not closed or isinstance(p.predefined, StateFeedback)
    rng = np.random.default_rng(7)
    N = round(seconds / p.Ts)
    excitation = np.repeat(rng.choice([-1.0, 1.0], N // 20 + 1), 20)[:N]
    x = np.zeros(A.shape[0])
    u, y = np.empty(N), np.empty(N)
    for k in range(N):
        y[k] = (d.C @ x)[0]
        u[k] = excitation[k] - float(np.atleast_1d(K @ x)[0]) if closed else excitation[k]
        x = d.A @ x + d.B[:, 0] * u[k]
    order = int(np.linalg.matrix_rank(ct.obsv(A, C[:1]) @ ct.ctrb(A, B)))  # Hankel rank
    return u, y, order, p.Ts


# Not here yet (issue 26): the belt in closed loop (its predefined law is a PID, not
# state feedback) and the double pendulum, whose six poles crowd z = 1 at 1 kHz: an ARX
# model of its order fits its own estimation data at 93 % (the coefficients' round-off
# moves clustered roots), so its noise-free fit needs a better-conditioned estimator.
CASES = [
    ("flexible_link", 60.0, True),
    ("flexible_link", 20.0, False),
    ("belt_conveyor", 20.0, False),
]


@pytest.mark.parametrize(("pid", "seconds", "closed"), CASES)
def test_a_noise_free_run_of_each_plant_fits_its_validation_part(
    pid: str, seconds: float, closed: bool
) -> None:
    u, y, n, Ts = record(pid, seconds, closed)
    ze, zv = iddata(y, u, Ts).split(0.5)
    m = arx(ze, n, n, 1)
    assert compare(m, ze, x0="estimate").fit[0] > 99.9
    assert compare(m, zv, x0="estimate").fit[0] > 99.9


def test_the_fitted_state_reproduces_data_the_model_made_itself() -> None:
    u, y, n, Ts = record("flexible_link", 60.0, True)
    ze, zv = iddata(y, u, Ts).split(0.5)
    m = arx(ze, n, n, 1)
    x0 = np.linspace(0.3, -0.2, m.nx)
    own = iddata(m.simulate(zv.u, x0)[:, 0], zv.u[:, 0], Ts)
    assert compare(m, own, x0="estimate").fit[0] > 99.99
