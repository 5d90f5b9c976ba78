"""Design on a given model (elab.design.model, observed, loop, locus): discrete LQR equals
python-control's dlqr; the inverse zero-order hold undoes c2d; state feedback on an
observer puts the poles where asked and keeps state feedback's step (the separation
principle); the law a run takes steps exactly the loop the design analysed; the root
locus passes through the design; PID on a model is the simulator's PID."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from elab.controllers import law_file, read_controller
from elab.design import loop, observed
from elab.design.locus import root_locus
from elab.design.model import Model, continuous, in_domain
from elab.design.response import margins
from elab.design.synthesis import dlqr
from elab.errors import InvalidInput
from elab.laws import PID, LTIController
from elab.plants import get_plant
from elab.sim.controllers import discretise

FLEX = get_plant("flexible_link")
BELT = get_plant("belt_conveyor")
Ts = 0.001


def zoh(plant=FLEX, Ts: float = Ts) -> Model:  # type: ignore[no-untyped-def]
    """The plant's exact ZOH model from u to its reference output."""
    ref = [plant.reference_output]
    d = ct.c2d(ct.ss(plant.A, plant.B, plant.C[ref], plant.D[ref]), Ts, "zoh")
    return Model.checked(d.A, d.B, d.C, d.D, Ts)


def test_dlqr_is_python_controls_and_refuses_what_has_no_solution() -> None:
    m = zoh()
    Q, R = np.diag([10.0, 200.0, 1.0, 0.5]), 0.3
    K, _, E = ct.dlqr(m.A, m.B, Q, R)
    got = dlqr(m.A, m.B, Q, R)
    # python-control 0.10's dlqr on the same matrices: the same solver, so to round-off
    np.testing.assert_allclose(got.K, K, rtol=1e-12, atol=0)
    np.testing.assert_allclose(np.sort_complex(got.poles), np.sort_complex(E), rtol=1e-9)
    assert np.all(np.abs(got.poles) < 1)
    # an unstable mode that u cannot move, and an integrator Q does not see
    with pytest.raises(InvalidInput, match="unit disc"):
        dlqr(np.diag([1.1, 0.5]), [[0.0], [1.0]], np.eye(2), 1.0)
    with pytest.raises(InvalidInput, match="unit circle"):
        dlqr(np.diag([1.0, 0.5]), [[1.0], [1.0]], np.diag([0.0, 1.0]), 1.0)


def test_the_inverse_zero_order_hold_gives_the_continuous_model_back() -> None:
    back = continuous(zoh())
    # c2d then its inverse: the physics model to round-off of the matrix logarithm
    np.testing.assert_allclose(back.A, FLEX.A, atol=1e-7 * np.abs(FLEX.A).max())
    np.testing.assert_allclose(back.B, FLEX.B, atol=1e-7 * np.abs(FLEX.B).max())
    assert back.Ts is None and in_domain(back, "continuous") is back
    with pytest.raises(InvalidInput, match="design it in discrete time"):
        continuous(Model.checked([[-0.5]], [[1.0]], [[1.0]], [[0.0]], 0.1))
    with pytest.raises(InvalidInput, match="no sample time"):
        in_domain(back, "discrete")


@pytest.mark.parametrize("discrete", [True, False])
def test_state_feedback_on_an_observer_keeps_the_state_feedbacks_step(discrete: bool) -> None:
    m = zoh() if discrete else continuous(zoh())
    K = observed.lqr_gain(m, observed.output_weight(m, 300.0), 1.0).K
    fb = observed.observed_feedback(m, K)
    a = loop.analyse(m, fb.controller, 0.5, T=2.0)
    # the poles: A − BK's and A − LC's (defining properties of the two designs)
    sf = np.linalg.eigvals(m.A - m.B @ K)
    ob = np.linalg.eigvals(m.A - fb.L @ m.C)
    np.testing.assert_allclose(np.sort_complex(ob), np.sort_complex(fb.observer_poles), rtol=1e-6)
    np.testing.assert_allclose(
        np.sort_complex(a.loop.poles), np.sort_complex(np.concatenate([sf, ob])), rtol=1e-6
    )
    # the default observer: three times faster, s → 3s, z → z³
    want = sf**3 if discrete else 3 * sf
    np.testing.assert_allclose(np.sort_complex(fb.observer_poles), np.sort_complex(want), rtol=1e-9)
    # r does not excite the estimation error: the step is state feedback's with Nr
    sys = ct.ss(m.A - m.B @ K, m.B * fb.Nr, m.C - m.D @ K, m.D * fb.Nr, Ts if discrete else 0)
    t = a.step.t
    want_y = ct.forced_response(sys, t, np.full(t.size, 0.5)).outputs
    np.testing.assert_allclose(a.step.y[0], np.ravel(want_y), atol=1e-9)
    assert a.loop.stable and a.step.y[0][-1] == pytest.approx(0.5, rel=1e-3)  # unit DC gain


def test_the_law_a_run_takes_steps_the_loop_the_design_analysed() -> None:
    m = zoh()
    fb = observed.observed_feedback(m, observed.lqr_gain(m, observed.output_weight(m, 300), 1).K)
    law = observed.feedback_law(m, fb.controller)
    assert isinstance(law, LTIController) and law.dt == Ts and law.B_r is not None
    # the simulator's own discrete controller for that law, on the plant's θ
    d = discretise(law, FLEX, Ts)
    on_theta = [0, 1 + FLEX.reference_output]
    stepped = ct.ss(d.Ac, d.Bc[:, on_theta], d.Cc.reshape(1, -1), d.Dc[on_theta].reshape(1, -1), Ts)
    a = loop.analyse(m, fb.controller, 0.3, T=1.0)
    b = loop.step(loop.close(m, stepped), Ts, 0.3, T=1.0)
    np.testing.assert_allclose(b.y, a.step.y, atol=1e-12)
    np.testing.assert_allclose(b.u, a.step.u, atol=1e-9)
    # the controller alone is unstable here (|z| > 1): one realisation shares its states
    # between r and e, where a separate feed-forward of the same dynamics would diverge
    assert np.max(np.abs(np.linalg.eigvals(fb.controller.A))) > 1
    # and it is a controller file, in every format, read back as the same law
    for fmt in ("toml", "json", "mat", "npz"):
        assert read_controller(law_file(FLEX, law, fmt, "on a model"), fmt, FLEX).law == law


def test_the_root_locus_passes_through_the_design_and_starts_at_the_open_loop() -> None:
    m = continuous(zoh())
    fb = observed.observed_feedback(m, observed.place_gain(m, [-4, -5, -6, -7]).K)
    lp = loop.close(m, fb.controller)
    rl = root_locus(lp.L)
    j = int(np.flatnonzero(rl.gains == 1.0)[0])
    np.testing.assert_allclose(
        np.sort_complex(rl.branches[:, j]), np.sort_complex(lp.poles), rtol=1e-7, atol=1e-9
    )
    np.testing.assert_allclose(
        np.sort_complex(rl.poles), np.sort_complex(np.linalg.eigvals(lp.L.A)), atol=1e-12
    )
    # the margins as design.response.margins gives them for the same continuous loop
    assert loop.loop_margins(lp, None) == margins(lp.L)


def test_pid_on_a_model_is_the_simulators_pid() -> None:
    m = zoh(BELT)
    law = PID(12.0, 0.49, 0.5)
    C = observed.pid_controller(m, law)
    d = discretise(law, BELT, Ts)  # Tustin of the same PID, with explicit states
    on_y = [0, 1 + BELT.reference_output]
    sim = ct.ss(d.Ac, d.Bc[:, on_y], d.Cc.reshape(1, -1), d.Dc[on_y].reshape(1, -1), Ts)
    a = loop.step(loop.close(m, C), Ts, 0.1, T=2.0)
    b = loop.step(loop.close(m, sim), Ts, 0.1, T=2.0)
    np.testing.assert_allclose(a.y, b.y, atol=1e-12)
    np.testing.assert_allclose(a.u, b.u, atol=1e-9)


def test_a_model_and_its_designs_refuse_bad_numbers_by_name() -> None:
    with pytest.raises(InvalidInput, match=r"^B:"):
        Model.checked([[1.0, 0], [0, 1]], [[1.0, 0], [0, 1]], [[1.0, 0]], [[0.0]], 0.1)
    with pytest.raises(InvalidInput, match=r"^A:"):
        Model.checked(np.eye(21), np.ones((21, 1)), np.ones((1, 21)), [[0.0]], 0.1)
    with pytest.raises(InvalidInput, match=r"^Ts:"):
        Model.checked([[0.5]], [[1.0]], [[1.0]], [[0.0]], 1e-9)
    m = zoh()
    with pytest.raises(InvalidInput, match=r"^K:"):
        observed.observed_feedback(m, [1.0, 2.0])
    with pytest.raises(InvalidInput, match=r"^K:.*passes a constant reference"):
        observed.observed_feedback(m, [0.0, 0.0, 0.0, 0.0])  # the integrator stays at z = 1
    with pytest.raises(InvalidInput, match=r"^observer_poles:"):
        observed.observed_feedback(m, [20, -90, 3, 1], [0.5])


@pytest.mark.parametrize("a", [1.2, 2.0])
def test_the_robust_weight_lowers_q_until_the_margins_hold_or_says_it_cannot(a: float) -> None:
    """The robust rule on a one-state discrete plant with its pole at ``a``: at 1.2 a
    lower q gives the loop 6 dB and 30° (its own margins computed again agree, and the
    note says from what to what); at 2.0 no q down to q/4096 does, q is kept and the
    note says so."""
    from elab.api.designs import GAIN_MARGIN_DB, PHASE_MARGIN_DEG, _robust

    m = Model(np.array([[a]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[0.0]]), 1.0)
    K, weight = _robust(m, 100.0, 1.0, None, "the given q")
    assert weight.note is not None
    if a == 1.2:
        assert weight.q < 100 and weight.note.startswith("q lowered from 100 (the given q)")
        lp = loop.close(m, observed.observed_feedback(m, K).controller)
        margins = loop.loop_margins(lp, m.Ts)
        assert margins.gain_margin_db >= GAIN_MARGIN_DB
        assert margins.phase_margin_deg >= PHASE_MARGIN_DEG
    else:
        assert weight.q == 100 and "kept: no q down to" in weight.note
