"""The stepping loop against python-control, the matrix exponential, and itself."""

from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from elab.laws import PID, LTIController, OpenLoop, StateFeedback
from elab.plants import PLANTS, get_plant
from elab.sim import (
    PRBS,
    Batch,
    RunSpec,
    Samples,
    Simulation,
    Sine,
    Square,
    Step,
    compile_run,
    simulate,
)
from elab.sim.batch import SignalFault
from tests.unit.conftest import discrete_loop

FLEX = get_plant("flexible_link")


def _default_spec(plant_id: str, **kw: object) -> RunSpec:
    p = get_plant(plant_id)
    ref = (
        Square(p.signal.amplitude, p.signal.period)
        if p.signal.kind == "square"
        else Step(p.signal.amplitude)
    )
    return RunSpec(p, p.predefined, ref, **{"duration": 3.0, **kw})  # type: ignore[arg-type]


@pytest.mark.parametrize("plant_id", sorted(PLANTS))
def test_linear_loop_matches_forced_response(plant_id: str) -> None:
    # reference: python-control forced_response on the same discrete loop, 1e-9 relative
    spec = _default_spec(plant_id, saturate=False)
    run = compile_run(spec)
    res = simulate(spec)
    loop = discrete_loop(run)
    r = spec.reference.sample(0, run.n_samples, run.Ts)
    fr = ct.forced_response(loop, T=np.arange(run.n_samples) * run.Ts, U=r)
    ny = spec.plant.ny
    y_dev = res.y - spec.plant.C @ spec.plant.operating_point  # results are absolute
    scale = np.max(np.abs(fr.outputs), axis=1, keepdims=True)
    assert_allclose(y_dev.T / scale[:ny], fr.outputs[:ny] / scale[:ny], rtol=0, atol=1e-9)
    assert_allclose(res.u / scale[ny], fr.outputs[ny] / scale[ny], rtol=0, atol=1e-9)


def test_zoh_is_exact_for_constant_input() -> None:
    # reference: x(t) from the matrix exponential of [[A, B], [0, 0]] t (Van Loan)
    p = get_plant("belt_conveyor")
    res = simulate(RunSpec(p, OpenLoop(), Step(2.0), duration=1.0, saturate=False))
    M = np.zeros((p.nx + 1, p.nx + 1))
    M[: p.nx, : p.nx], M[: p.nx, p.nx :] = p.A, p.B
    for k in (1, 10, 437, 999):
        x_exact = (scipy.linalg.expm(M * k * res.Ts) @ np.r_[np.zeros(p.nx), 2.0])[: p.nx]
        assert_allclose(res.x[k], x_exact, rtol=1e-9, atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(
    K=st.lists(st.floats(-200, 200), min_size=4, max_size=4),
    amp=st.floats(0.01, 3.0),
    u_max=st.floats(0.5, 20.0),
)
def test_saturation_bounds_every_sample(K: list[float], amp: float, u_max: float) -> None:
    res = simulate(
        RunSpec(FLEX, StateFeedback(tuple(K)), Square(amp, 1.0), duration=2.0, u_max=u_max)
    )
    assert np.all(np.abs(res.u) <= u_max)


@pytest.mark.parametrize("plant_id", sorted(PLANTS))
def test_chunks_give_the_samples_of_a_whole_run(plant_id: str) -> None:
    # noise, quantisation and an excitation exercise every exogenous path
    spec = _default_spec(plant_id, noise_seed=7, quantize=True, excitation=PRBS(0.5, 7, 0.2))
    whole = simulate(spec)
    sim, parts = Simulation(spec, block=300), []
    sizes = np.random.default_rng(0).integers(1, 700, size=1000)
    for n in sizes:
        if not sim.remaining:
            break
        parts.append(sim.advance(int(n)))
    chunked = Samples.concatenate(parts)
    for f in "ruyx":
        np.testing.assert_array_equal(getattr(chunked, f), getattr(whole, f))


def test_same_seed_same_bits_other_seed_other_noise() -> None:
    a = simulate(_default_spec("flexible_link", noise_seed=3))
    b = simulate(_default_spec("flexible_link", noise_seed=3))
    c = simulate(_default_spec("flexible_link", noise_seed=4))
    np.testing.assert_array_equal(a.y, b.y)
    assert not np.array_equal(a.y, c.y)


def test_batch_of_mixed_plants_equals_runs_alone() -> None:
    # zero padding to the largest plant must not change a single bit
    specs = [_default_spec(pid, noise_seed=1) for pid in sorted(PLANTS)] * 2
    batch = Batch(capacity=1, block=500)
    slots = [batch.add(compile_run(s)) for s in specs]
    got: dict[int, list[Samples]] = {s: [] for s in slots}
    for _ in range(6):
        batch.advance(500)
        for s in slots:
            got[s].append(batch.samples(s))
    for spec, s in zip(specs, slots, strict=True):
        alone = simulate(spec)
        np.testing.assert_array_equal(Samples.concatenate(got[s]).y, alone.y)


def test_a_larger_plant_joining_a_running_batch_changes_nothing() -> None:
    # a live server: a flexible link steps alone, then a pendulum (more outputs and
    # states) and a belt join; the block widens and every run stays bit-exact
    specs = [
        _default_spec(pid, noise_seed=2)
        for pid in ("flexible_link", "double_pendulum", "belt_conveyor")
    ]
    batch = Batch(capacity=4, block=500)  # room for all: only the width grows
    got: dict[int, list[Samples]] = {}
    for spec in specs:
        got[batch.add(compile_run(spec))] = []
        for _ in range(2):
            block = batch.advance(500)
            for s in got:
                ys, xs = batch.columns(s)
                p = spec_of(specs, s).plant
                assert block[s, :, ys].shape == (500, p.ny)
                assert block[s, :, xs].shape == (500, p.nx)
                np.testing.assert_array_equal(block[s, :, ys], batch.samples(s).y)
                got[s].append(batch.samples(s))
    for s, chunks in got.items():
        spec, mine = spec_of(specs, s), Samples.concatenate(chunks)
        n = mine.y.shape[0]
        alone = simulate(RunSpec(**{**spec.__dict__, "duration": (n + 10) * spec.plant.Ts}))
        np.testing.assert_array_equal(mine.y, alone.y[:n])
        np.testing.assert_array_equal(mine.x, alone.x[:n])


def spec_of(specs: list[RunSpec], slot: int) -> RunSpec:
    return specs[slot]


def test_runs_joining_mid_block_refill_their_signals_bit_exact() -> None:
    """Growing the batch generates every run's signals again from its next sample (they
    are not copied): a run 300 samples into a block of 1,000 when a larger plant joins
    goes on with exactly the samples it has alone, noise and square wave included."""
    specs = [
        _default_spec(pid, noise_seed=5, excitation=PRBS(0.5, order=7))
        for pid in ("flexible_link", "double_pendulum", "belt_conveyor")
    ]
    batch = Batch(capacity=1, block=1000)  # grows in runs, outputs and states
    got: dict[int, list[Samples]] = {}
    for spec in specs:
        got[batch.add(compile_run(spec))] = []
        for _ in range(3):
            batch.advance(300)
            for s in got:
                got[s].append(batch.samples(s))
    for s, chunks in got.items():
        mine = Samples.concatenate(chunks)
        alone = simulate(specs[s])
        for field in "ruyx":
            np.testing.assert_array_equal(getattr(mine, field), getattr(alone, field)[: mine.n])


@dataclass(frozen=True)
class _FailsAfter(Step):
    """A step whose values cannot be computed from sample ``bad`` on."""

    bad: int = 0

    def sample(self, k0: int, n: int, Ts: float) -> np.ndarray:
        if k0 + n > self.bad:
            raise ValueError("no value here")
        return super().sample(k0, n, Ts)


def test_a_run_whose_signals_fail_is_never_stepped_on_half_written_signals() -> None:
    """Signals are written straight into the batch's block: one that fails half-way is
    generated again before that run steps (the fault is raised again), and the others
    step on, bit-exact."""
    good = _default_spec("flexible_link", noise_seed=1)
    bad = _default_spec("flexible_link", excitation=_FailsAfter(0.1, bad=1500))
    batch = Batch(capacity=2, block=1000)
    slots = batch.add(compile_run(good)), batch.add(compile_run(bad))
    batch.advance(995)
    for n in (10, 5):  # 5 more fit in the block as it was before the failed refill
        with pytest.raises(SignalFault) as fault:
            batch.advance(n)
        assert fault.value.slot == slots[1] and fault.value.k == 995
    batch.advance(10, [slots[0]])
    np.testing.assert_array_equal(batch.samples(slots[0]).y, simulate(good).y[995:1005])


def test_quantisation_puts_outputs_on_the_encoder_grid() -> None:
    res = simulate(_default_spec("flexible_link", quantize=True))
    q = FLEX.sensors.quantum[0]
    assert_allclose(res.y / q, np.round(res.y / q), atol=1e-6)


def test_noise_has_the_sensor_standard_deviation() -> None:
    spec = RunSpec(FLEX, OpenLoop(), Step(0.0), duration=20.0, noise_seed=11)
    y = simulate(spec).y
    # 20 000 samples: the sample std is within 3 % of the true one with > 99.9 % probability
    assert_allclose(y.std(axis=0), FLEX.sensors.noise_std, rtol=0.03)
    assert abs(np.corrcoef(y[1:, 0], y[:-1, 0])[0, 1]) < 0.03  # white


def test_open_loop_marginal_plant_integrates() -> None:
    # belt conveyor: constant voltage → constant speed v = K_m · 0.048 · u (DC gains)
    p = get_plant("belt_conveyor")
    res = simulate(RunSpec(p, OpenLoop(), Step(1.0), duration=5.0))
    assert_allclose(res.y[-1, 1], 5.0 * 0.048, rtol=1e-6)


def test_pid_anti_windup_reduces_overshoot_after_saturation() -> None:
    p = get_plant("belt_conveyor")
    ref = Step(2.0)  # far enough to saturate at 10 V for a while
    aw = simulate(RunSpec(p, PID(12, 2.0, 0.5), ref, duration=15.0))
    no_aw = simulate(RunSpec(p, PID(12, 2.0, 0.5, Tt=1e9), ref, duration=15.0))
    assert np.max(np.abs(aw.u)) == pytest.approx(10.0)
    assert aw.y[:, 0].max() < no_aw.y[:, 0].max() - 0.05


def test_discrete_lti_controller_equals_its_continuous_tustin_twin() -> None:
    p = get_plant("belt_conveyor")
    num, den = (0.5, 12.0, 0.49), (1.0, 0.0)  # PI + P shape: (0.5 s² + 12 s + 0.49)/s... proper
    den = (0.01, 1.0, 0.0)
    cont = LTIController(num=num, den=den)
    d = ct.c2d(ct.tf(num, den), p.Ts, "tustin")
    disc = LTIController(num=tuple(d.num[0][0]), den=tuple(d.den[0][0]), dt=p.Ts)
    a = simulate(RunSpec(p, cont, Step(0.3), duration=2.0))
    b = simulate(RunSpec(p, disc, Step(0.3), duration=2.0))
    assert_allclose(a.y, b.y, rtol=1e-6, atol=1e-9)


def test_live_gain_change_takes_effect_at_the_next_sample() -> None:
    spec = _default_spec("flexible_link", saturate=False)
    sim = Simulation(spec)
    sim.advance(1000)
    sim.set_law(StateFeedback((0, 0, 0, 0), "velocity_filters"))
    after = sim.advance(10)
    assert_allclose(after.u, 0.0)  # zero gain → zero input from the change on


def test_diverging_loop_stops_with_its_index() -> None:
    spec = RunSpec(
        FLEX,
        StateFeedback((20, 20, 20, 20)),
        Square(math.radians(30), 4.0),
        duration=10.0,
        saturate=False,
    )
    res = simulate(spec)
    assert 0 < res.n < 10_000
    assert np.all(np.isfinite(res.x))
    sim = Simulation(spec)
    while sim.remaining:
        sim.advance(500)
    assert sim.diverged_at == res.n


def test_sine_steady_state_matches_the_loop_frequency_response() -> None:
    # reference: |T(e^{jωTs})| and ∠T of the discrete loop by python-control, 1e-4
    spec = RunSpec(FLEX, FLEX.predefined, Sine(0.2, 0.5), duration=20.0, saturate=False)
    res = simulate(spec)
    w = 2 * np.pi * 0.5
    t, y = res.t[10_000:], res.y[10_000:, 0]  # after the transient (poles ≥ 6 rad/s)
    basis = np.column_stack([np.sin(w * t), np.cos(w * t)])
    (a, b), *_ = np.linalg.lstsq(basis, y, rcond=None)
    T = ct.frequency_response(discrete_loop(compile_run(spec))[0, 0], [w]).complex[0]
    assert_allclose(np.hypot(a, b), 0.2 * abs(T), rtol=1e-4)
    assert_allclose(np.arctan2(b, a), np.angle(T), atol=1e-4)
