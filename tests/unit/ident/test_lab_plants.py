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

import math
from dataclasses import replace
from typing import Any

import control as ct
import numpy as np
import pytest

from elab.errors import InvalidInput
from elab.ident import iddata
from elab.ident.modeladvice import Physics
from elab.ident.models import LinearModel
from elab.ident.polynomial import arx
from elab.ident.validation import compare
from elab.ident.workflow import Plan, parse_model, run
from elab.laws import OpenLoop, StateFeedback
from elab.plants import Plant, get_plant
from elab.sim import PRBS, RunSpec
from elab.sim.engine import simulate


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


def prbs_run(p: Plant, **over: Any) -> RunSpec:
    """A run as the lab records one for identification: the predefined controller, the
    reference at 0, a 1 V PRBS at the input for 20 s (``over``: other settings)."""
    from elab.sim import Step

    return RunSpec(
        p,
        p.predefined,
        Step(0.0),
        duration=20.0,
        excitation=PRBS(1.0, order=10, band=0.05),
        excitation_at="input",
        **over,
    )


# Not here (issue 26): the double pendulum, whose six poles crowd z = 1 at 1 kHz: an ARX
# model of its order fits its own estimation data at 93 % (the coefficients' round-off
# moves clustered roots); subspace identification of all its outputs recovers them
# (test_the_double_pendulums_poles_by_subspace_from_its_operating_point below).
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


@pytest.mark.parametrize("pid", ["flexible_link", "belt_conveyor"])
def test_a_noise_free_closed_loop_run_gives_the_true_discrete_poles(pid: str) -> None:
    """Issue 26's item 2 on a run as the lab records it (the simulator, the predefined
    controller: the link's state feedback, the belt's PI; a PRBS at the input, ideal
    sensors): ARX of the plant's order has the plant's discrete poles within 1e-6
    (relative) and fits the validation part from its fitted state above 99.9 %."""

    p = get_plant(pid)
    s = simulate(prbs_run(p))
    A, B, C = (np.asarray(m, dtype=float) for m in (p.A, p.B, p.C))
    j = p.reference_output
    n = int(np.linalg.matrix_rank(ct.obsv(A, C[j : j + 1]) @ ct.ctrb(A, B)))
    ze, zv = iddata(s.y[:, j], s.u, s.Ts).split(0.5)
    m = arx(ze, n, n, 1)
    true = np.linalg.eigvals(ct.c2d(ct.ss(A, B, C[j : j + 1], 0), s.Ts).A)
    for z in true:
        assert np.min(np.abs(m.poles - z)) <= 1e-6 * abs(z), (z, m.poles)
    assert compare(m, zv, x0="estimate").fit[0] > 99.9


def test_the_fitted_state_reproduces_data_the_model_made_itself() -> None:
    u, y, n, Ts = record("flexible_link", 60.0, True)
    ze, zv = iddata(y, u, Ts).split(0.5)
    m = arx(ze, n, n, 1)
    x0 = np.linspace(0.3, -0.2, m.nx)
    own = iddata(m.simulate(zv.u, x0)[:, 0], zv.u[:, 0], Ts)
    assert compare(m, own, x0="estimate").fit[0] > 99.99


def link_bode_gap(m: LinearModel) -> tuple[float, float]:
    """The largest |dB| and |°| between ``m`` (θ/u) and the link's physics model over
    2–60 rad/s, outside ±15 % of the antiresonance (θ/u's zeros at ±18.9j)."""
    p = get_plant("flexible_link")
    A, B, C = (np.asarray(x, dtype=float) for x in (p.A, p.B, p.C))
    w = np.logspace(np.log10(2.0), np.log10(60.0), 200)
    w = w[np.abs(w / 18.9 - 1) > 0.15]
    physics = np.squeeze(ct.frequency_response(ct.ss(A, B, C[:1], 0), w).complex)
    model = np.squeeze(ct.frequency_response(ct.ss(m.A, m.B, m.C[:1], m.D[:1], m.Ts), w).complex)
    ratio = model / physics
    return float(np.max(np.abs(20 * np.log10(np.abs(ratio))))), float(
        np.max(np.abs(np.degrees(np.angle(ratio))))
    )


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_links_proposals_on_the_pages_default_run_match_its_physics(seed: int) -> None:
    """Issue 26's item 4: the identification page's default run of the link (30 s, a
    1 V PRBS at the input under the predefined controller, realistic sensors) with the
    plant's proposals (oe:4,4,1 and n4sid:4 on every 10th sample, kept as recorded):
    within 3 dB and 15° of the physics model, and no verdict calls them poor."""
    p = get_plant("flexible_link")
    spec = RunSpec(
        p,
        p.predefined,
        duration=30.0,
        excitation=PRBS(1.0, order=10, band=0.05),
        excitation_at="input",
        noise_seed=seed,
        quantize=True,
    )
    s = simulate(spec)
    z = iddata(s.y[:, 0], s.u, s.Ts, output_names=("theta",), input_names=("u",))
    proposals = p.identification
    plan = Plan(
        models=tuple(parse_model(m) for m in proposals.models.split(";")),
        detrend="none",
        decimate=proposals.decimate,
        closed_loop=True,
        correlation=False,
        spectral=False,
    )
    result = run(z, plan)
    for m in result.models:
        db, deg = link_bode_gap(m.model)
        assert db < 3.0 and deg < 15.0, (m.name, db, deg)
        assert m.level != "poor", (m.name, m.verdicts)
        assert m.fits.headline_fit.fit[0] > 85, m.name


@pytest.mark.parametrize("seed", [1, 2])
def test_the_belts_proposals_on_the_pages_default_run_match_its_physics(seed: int) -> None:
    """The belt's proposals (oe:4,4,1 and n4sid:4 on every 10th sample) on the page's
    default run (30 s, a 1 V PRBS at the input under the PI, the reference at 0,
    realistic sensors, kept as recorded): the physics verdict good (within 3 dB and 15°
    of the plant's own model), no verdict poor, fits above 95 %. The general proposal
    fails there: its ARX model is poor against the physics."""
    from elab.ident.modeladvice import physics_of
    from elab.sim import Step

    p = get_plant("belt_conveyor")
    spec = RunSpec(
        p,
        p.predefined,
        duration=30.0,
        reference=Step(0.0),
        excitation=PRBS(1.0, order=10, band=0.05),
        excitation_at="input",
        noise_seed=seed,
        quantize=True,
    )
    s = simulate(spec)
    z = iddata(s.y[:, 0], s.u, s.Ts, output_names=("x",), input_names=("u",))
    plan = Plan(
        models=tuple(parse_model(m) for m in p.identification.models.split(";")),
        detrend="none",
        decimate=p.identification.decimate,
        closed_loop=True,
        correlation=False,
        spectral=False,
        physics=physics_of(p, ("x",), s.Ts, False),
    )
    for m in run(z, plan).models:
        physics = {v.topic: v for v in m.verdicts}["physics"]
        assert physics.level == "good", (m.name, physics)
        assert m.level != "poor", (m.name, m.verdicts)
        assert m.fits.headline_fit.fit[0] > 95, m.name
    general = replace(plan, models=(parse_model("arx:4,4,1"),), decimate=1)
    arx_ = run(z, general).models[0]
    assert {v.topic: v for v in arx_.verdicts}["physics"].level == "poor"


def test_a_too_small_excitation_is_named_with_its_fix_and_open_loop_is_believed() -> None:
    """Issue 26's poor experiment: the link's default run with a 0.02 V PRBS moves θ by
    two encoder counts; the verdicts say the noise and the quantisation swamp it and by
    how much to raise the excitation, and the models fail against the physics. A run
    without a controller is open loop, whatever a test on its data would guess."""
    p = get_plant("flexible_link")
    physics = Physics(*(np.asarray(m, dtype=float) for m in (p.A, p.B, p.C[:1], p.D[:1])))
    plan = Plan(
        models=(parse_model("oe:4,4,1"),),
        detrend="none",
        decimate=10,
        physics=replace(physics, hold=p.Ts),
        closed_loop=True,
    )
    for amplitude, law, closed in ((0.02, p.predefined, True), (1.0, OpenLoop(), False)):
        spec = RunSpec(
            p,
            law,
            duration=30.0,
            excitation=PRBS(amplitude, order=10, band=0.05),
            excitation_at="input",
            noise_seed=1,
            quantize=True,
        )
        s = simulate(spec)
        z = iddata(s.y[:, 0], s.u, s.Ts, output_names=("theta",), input_names=("u",))
        result = run(z, replace(plan, closed_loop=closed))
        said = {v.topic: v for v in result.verdicts}
        if closed:
            assert said["noise"].level == "poor" and "raise the excitation" in str(
                said["noise"].advice
            )
            assert said["quantisation"].level == "caution"
            model = {v.topic: v for v in result.models[0].verdicts}
            assert model["physics"].level == "poor" and result.models[0].level == "poor"
        else:
            assert said["feedback"].level == "good" and "open loop" in said["feedback"].finding
            assert result.models[0].level != "poor", result.models[0].verdicts


def test_the_double_pendulums_poles_by_subspace_from_its_operating_point() -> None:
    """The double pendulum, noise-free, as the lab records it (its predefined LQR on the
    true state, a 1 V PRBS at the input, ideal sensors): n4sid of order 6 on its three
    outputs, with the operating point's outputs taken off (β₂ sits at π), has the
    plant's six discrete poles, the unstable one (z = 1.0052) and the integrator's
    included, within 1e-6 (relative; 1e-14 measured). Taking the mean off instead moves
    them by 1.6e-4 (the arm integrates: a mean taken off u adds a ramp), and keeping π
    in β₂ by 6.4e-3: the offset, not the estimator, was what failed here."""
    from elab.ident.subspace import n4sid

    p = get_plant("double_pendulum")
    s = simulate(prbs_run(p, quantize=False))
    A, B, C = (np.asarray(m, dtype=float) for m in (p.A, p.B, p.C))
    true = np.linalg.eigvals(ct.c2d(ct.ss(A, B, C, 0), s.Ts).A)
    y = s.y - C @ np.asarray(p.operating_point, dtype=float)
    model = n4sid(iddata(y, s.u, s.Ts), 6, horizon=20, stable=False)
    for z in true:
        assert np.min(np.abs(model.poles - z)) <= 1e-6 * abs(z), (z, model.poles)
    mean_off = n4sid(iddata(y, s.u, s.Ts).detrend(), 6, horizon=20, stable=False)
    assert max(np.min(np.abs(mean_off.poles - z)) / abs(z) for z in true) > 1e-5


def test_the_operating_point_detrend_takes_off_the_plants_rest_and_nothing_else() -> None:
    """``detrend="operating_point"`` takes the plant's rest off every channel: the
    pendulum's analysed record is its recording less (0, 0, π) on the outputs and 0 on u,
    sample for sample; without the rest given (a file), it is refused by name."""
    p = get_plant("double_pendulum")
    u = np.random.default_rng(1).standard_normal(600)
    y = np.column_stack([np.cumsum(u) * 1e-3, 1e-3 * u, np.pi + 1e-3 * np.roll(u, 2)])
    names = tuple(o.name for o in p.outputs)
    data = iddata(y, u, p.Ts, output_names=names, input_names=("u",))
    rest = (tuple(p.rest[n] for n in names), (p.rest["u"],))
    assert rest == ((0.0, 0.0, math.pi), (0.0,))
    assert p.rest["r"] == 0.0 and p.rest["x_beta2"] == math.pi and p.rest["x_beta2_dot"] == 0
    plan = Plan(
        models=(parse_model("arx:2,2,1"),),
        detrend="operating_point",
        operating_point=rest,
        correlation=False,
        spectral=False,
    )
    result = run(data, plan)
    np.testing.assert_array_equal(result.data.z.y, y - np.array(rest[0]))
    np.testing.assert_array_equal(result.data.z.u[:, 0], u)
    assert any(n.startswith("the plant's rest taken off every sample") for n in result.notes)
    with pytest.raises(InvalidInput) as refused:
        run(data, replace(plan, operating_point=None))
    assert refused.value.field == "detrend"


def test_a_channel_with_no_rest_is_refused_by_name() -> None:
    """A rig run records its loop's latency beside the plant's signals: it has no value
    at the plant's rest, so ``operating_point`` on it is refused naming ``detrend``."""
    from elab.api.convert import Requested
    from elab.api.ident import _rest
    from elab.api.schemas import IdentRequest

    ran = Requested(None, None, None, False, None, True, "flexible_link", True)
    req = IdentRequest.model_validate(
        {"data": {"source": "run", "run": "r-1"}, "detrend": "operating_point"}
    )
    data = iddata(np.arange(4.0), np.ones(4), 0.001, output_names=("theta",), input_names=("u",))
    assert _rest(req, data, ran) == ((0.0,), (0.0,))
    late = iddata(np.arange(4.0), np.ones(4), 0.001, output_names=("latency",), input_names=("u",))
    with pytest.raises(InvalidInput) as refused:
        _rest(req, late, ran)
    assert refused.value.field == "detrend" and "'latency'" in str(refused.value)


def test_an_unstable_plants_subspace_model_keeps_its_unstable_pole_and_says_why() -> None:
    """The double pendulum, noise-free as in the test above, through the workflow as the
    lab runs it (its physics known, its rest taken off): n4sid 6 keeps the plant's
    unstable pole (z = 1.0052) instead of reflecting it, the stability verdict calls
    that right, the simulated fit is not taken as a judgement (it grows with the mode),
    and a note says so. The same data as a file (no physics) keep the default, which
    judges the estimate against its reflection by simulation and reflects the pole."""
    from elab.ident.modeladvice import physics_of

    p = get_plant("double_pendulum")
    s = simulate(prbs_run(p, quantize=False))
    names = tuple(o.name for o in p.outputs)
    z = iddata(s.y, s.u, s.Ts, output_names=names, input_names=("u",))
    A, B, C = (np.asarray(m, dtype=float) for m in (p.A, p.B, p.C))
    true = np.linalg.eigvals(ct.c2d(ct.ss(A, B, C, 0), s.Ts).A)
    unstable = true[np.abs(true) > 1][0]
    plan = Plan(
        models=(parse_model("n4sid:6"),),
        detrend="operating_point",
        operating_point=(tuple(p.rest[n] for n in names), (0.0,)),
        horizon=20,
        closed_loop=True,
        correlation=False,
        spectral=False,
        physics=physics_of(p, names, s.Ts, False),
    )
    result = run(z, plan)
    m = result.models[0]
    assert np.min(np.abs(m.model.poles - unstable)) <= 1e-6 * abs(unstable), m.model.poles
    said = {v.topic: v for v in m.verdicts}
    assert (
        said["stability"].level == "good" and "unstable like the plant" in said["stability"].finding
    )
    assert said["fit"].level == "caution" and "does not judge" in said["fit"].finding
    assert any(n.startswith("the plant is unstable") for n in result.notes), result.notes
    as_file = run(z, replace(plan, physics=None)).models[0]
    assert np.max(np.abs(as_file.model.poles)) <= 1.0  # reflected by the simulation's choice
