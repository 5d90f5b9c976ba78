"""The declarative controller's extras, each checked against python-control: PID setpoint
weights, a reference gain, a Luenberger observer (given L or placed poles), a feed-forward
(continuous and discrete), and a chain of blocks in series; and their files."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest

from elab.controllers import law_fields, law_from_fields, read_controller
from elab.design.plant_loop import closed_loop
from elab.design.realise import pid_filter_time, realise
from elab.errors import InvalidInput
from elab.laws import PID, LTIController, StateFeedback
from elab.plants import get_plant
from elab.sim import RunSpec, Square, simulate
from elab.sim.controllers import discretise

FLEX = get_plant("flexible_link")
BELT = get_plant("belt_conveyor")
SEED_LQR = (20.0, -93.5614, 3.3621, 0.9623)
W = np.array([0.1, 1.0, 7.0, 40.0, 300.0])  # rad/s, where responses are compared


def response(sys: ct.StateSpace, inp: int, w: np.ndarray = W) -> np.ndarray:
    """Frequency response of output 0 to input ``inp``."""
    return np.array(
        [
            np.asarray(sys(_point(sys, x), squeeze=False)).reshape(sys.noutputs, sys.ninputs)[
                0, inp
            ]
            for x in w
        ]
    )


def _point(sys: ct.StateSpace, w: float) -> complex:
    return complex(1j * w) if not sys.dt else complex(np.exp(1j * w * sys.dt))


def test_pid_setpoint_weights_act_on_the_reference_only() -> None:
    """r → u is Kp b + Ki/s + c Kd s/(Tf s + 1); y → u the unweighted PID; to 1e-9."""
    law = PID(12.0, 0.49, 0.5, b=0.4, c=0.0)
    sys = realise(BELT, law).ss()
    Tf = pid_filter_time(law)
    s = ct.tf("s")
    from_r = 12.0 * 0.4 + 0.49 / s + 0.0 * 0.5 * s / (Tf * s + 1)
    from_y = -(12.0 + 0.49 / s + 0.5 * s / (Tf * s + 1))
    assert np.allclose(response(sys, 0), response(ct.ss(from_r), 0), rtol=1e-9)
    assert np.allclose(response(sys, 1), response(ct.ss(from_y), 0), rtol=1e-9)
    # the loop (poles) is that of the unweighted PID: weights change only the reference path
    a = np.sort_complex(np.linalg.eigvals(closed_loop(BELT, law).A))
    b = np.sort_complex(np.linalg.eigvals(closed_loop(BELT, PID(12.0, 0.49, 0.5)).A))
    assert np.allclose(a, b)
    weighted = simulate(RunSpec(BELT, law, Square(0.1, 4.0), duration=6.0))
    plain = simulate(RunSpec(BELT, PID(12.0, 0.49, 0.5), Square(0.1, 4.0), duration=6.0))
    assert np.abs(weighted.u).max() < 0.3 * np.abs(plain.u).max()  # no proportional kick


def test_a_reference_gain_replaces_the_reference_states_gain() -> None:
    law = StateFeedback(SEED_LQR, "true_state", Nr=25.0)
    real = realise(FLEX, law)
    assert real.D_r[0, 0] == 25.0 and np.array_equal(real.D_m, -np.array([SEED_LQR]))
    assert realise(FLEX, StateFeedback(SEED_LQR, "true_state")).D_r[0, 0] == 20.0


def test_an_observer_adds_its_poles_to_the_state_feedbacks_and_tracks_like_it() -> None:
    """Separation: the closed loop's poles are eig(A − BK) and the observer's, placed by
    python-control; a run with the observer follows the true-state run within 1 % of the
    step once the observer has converged."""
    poles = (-40.0, -45.0, complex(-50, 8), complex(-50, -8))
    law = StateFeedback(SEED_LQR, "observer", observer_poles=poles)
    loop = np.sort_complex(np.linalg.eigvals(closed_loop(FLEX, law).A))
    A, B = FLEX.A, FLEX.B
    expected = np.concatenate([np.linalg.eigvals(A - B @ np.array([SEED_LQR])), poles])
    assert np.allclose(loop, np.sort_complex(expected), atol=1e-6)
    L = ct.place(A.T, FLEX.C.T, poles).T
    given = StateFeedback(SEED_LQR, "observer", L=tuple(map(tuple, L)))
    assert np.allclose(np.sort_complex(np.linalg.eigvals(closed_loop(FLEX, given).A)), loop)
    step = Square(math.radians(10), 4.0)
    a = simulate(RunSpec(FLEX, law, step, duration=8.0))
    b = simulate(RunSpec(FLEX, StateFeedback(SEED_LQR, "true_state"), step, duration=8.0))
    assert np.abs(a.y[500:, 0] - b.y[500:, 0]).max() < 0.01 * math.radians(10)


def test_a_feedforward_is_added_from_the_reference_continuous_and_discrete() -> None:
    C = (12.0, 0.49), (1.0, 0.0)
    F = (1.0,), (0.1, 1.0)
    law = LTIController(num=C[0], den=C[1], ff_num=F[0], ff_den=F[1])
    sys = realise(BELT, law).ss()
    want_r = ct.ss(ct.tf(*C) + ct.tf(*F))
    assert np.allclose(response(sys, 0), response(want_r, 0), rtol=1e-9)
    assert np.allclose(response(sys, 1), -response(ct.ss(ct.tf(*C)), 0), rtol=1e-9)
    dt = BELT.Ts
    Cd, Fd = ((12.0, -11.9), (1.0, -1.0)), ((0.5,), (1.0, -0.5))
    disc = discretise(
        LTIController(num=Cd[0], den=Cd[1], dt=dt, ff_num=Fd[0], ff_den=Fd[1]), BELT, dt
    )
    got = ct.ss(disc.Ac, disc.Bc, disc.Cc.reshape(1, -1), disc.Dc.reshape(1, -1), dt)
    want = ct.tf(*Cd, dt) + ct.tf(*Fd, dt)
    assert np.allclose(response(got, 0), response(ct.ss(want), 0), rtol=1e-9)


CHAIN = """version = 1
kind = "chain"
name = "PI and a lead"

[[blocks]]
kind = "pid"
Kp = 2.0
Ki = 0.5

[[blocks]]
kind = "lti"
num = [0.5, 1.0]
den = [0.05, 1.0]
"""


def test_a_chain_of_blocks_is_their_series_connection() -> None:
    ctrl = read_controller(CHAIN.encode(), "toml", BELT)
    assert ctrl.name == "PI and a lead" and isinstance(ctrl.law, LTIController)
    s = ct.tf("s")
    want = (2.0 + 0.5 / s) * (0.5 * s + 1) / (0.05 * s + 1)
    got = realise(BELT, ctrl.law).ss()
    assert np.allclose(response(got, 0), response(ct.ss(want), 0), rtol=1e-9)
    # it is stored as the LTI law it compiles to, and comes back the same
    assert law_from_fields(law_fields(ctrl.law), BELT) == ctrl.law
    discrete = CHAIN.replace(
        'kind = "pid"\nKp = 2.0\nKi = 0.5', 'kind = "lti"\nnum = [2, -1.9]\nden = [1, -1]'
    )
    discrete = discrete.replace('name = "PI and a lead"', 'name = "d"\ndt = 0.001')
    discrete = discrete.replace(
        "num = [0.5, 1.0]\nden = [0.05, 1.0]", "num = [1, -0.9]\nden = [1, -0.5]"
    )
    law = read_controller(discrete.encode(), "toml", BELT).law
    assert isinstance(law, LTIController) and law.dt == 0.001
    want_d = ct.tf([2, -1.9], [1, -1], 0.001) * ct.tf([1, -0.9], [1, -0.5], 0.001)
    from elab.design.realise import lti_ss

    assert np.allclose(response(lti_ss(law), 0), response(ct.ss(want_d), 0), rtol=1e-9)


@pytest.mark.parametrize(
    ("text", "field", "says"),
    [
        (CHAIN.replace("Ki = 0.5", "Ki = 0.5\nfoo = 1"), "blocks[0].foo", "a field of the block"),
        (CHAIN.replace('kind = "lti"', 'kind = "ss"'), "blocks[1].kind", "pid or lti"),
        (CHAIN.replace("den = [0.05, 1.0]", "den = [0, 1.0]"), "blocks[1].den", "not zero"),
        (CHAIN.replace('name = "PI and a lead"', "dt = 0.001"), "blocks[0]", "discrete"),
        ('version = 1\nkind = "chain"\nblocks = []\n', "blocks", "1 to 8 blocks"),
    ],
)
def test_a_bad_chain_names_the_block_and_field(text: str, field: str, says: str) -> None:
    with pytest.raises(InvalidInput, match=says) as err:
        read_controller(text.encode(), "toml", BELT)
    assert err.value.field == field


def test_observer_files_and_their_errors() -> None:
    head = 'version = 1\nkind = "state_feedback"\nK = [20, -93.5614, 3.3621, 0.9623]\n'
    ok = head + 'estimate = "observer"\nobserver_poles = [-40, -45, [-50, 8], [-50, -8]]\n'
    law = read_controller(ok.encode(), "toml", FLEX).law
    assert isinstance(law, StateFeedback) and law.observer_poles == (
        -40,
        -45,
        complex(-50, 8),
        complex(-50, -8),
    )
    assert law_from_fields(law_fields(law), FLEX) == law
    cases = [
        (head + 'estimate = "observer"\n', "estimate", "either L"),
        (head + 'estimate = "observer"\nL = [[1, 2]]\n', "L", "4×2"),
        (head + "L = [[1, 2], [1, 2], [1, 2], [1, 2]]\n", "L", 'estimate = "observer"'),
        (
            head + 'estimate = "observer"\nobserver_poles = [-40, -45]\n',
            "observer_poles",
            "4 poles",
        ),
        (
            head + 'estimate = "observer"\nobserver_poles = [-1, -2, [-3], -4]\n',
            "observer_poles[2]",
            r"\[re, im\]",
        ),
    ]
    for text, field, says in cases:
        with pytest.raises(InvalidInput, match=says) as err:
            read_controller(text.encode(), "toml", FLEX)
        assert err.value.field == field, text
    bad = head + 'estimate = "observer"\nobserver_poles = [-40, -40, -40, -40]\n'
    law = read_controller(bad.encode(), "toml", FLEX).law  # read fine; placing fails
    with pytest.raises(InvalidInput, match="placed") as err:
        realise(FLEX, law)
    assert err.value.field == "controller.observer_poles"
