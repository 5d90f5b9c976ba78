"""The supervisor between the controller and the amplifier: properties over any input
sequence (the voltage and its slew stay inside their limits; a trip is 0 V for good; N bad
samples in a row trip at exactly the Nth, fewer never), and one example per trip reason."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from elab.errors import InvalidInput
from elab.rig.supervisor import Decision, SafetyLimits, Supervisor, Trip, TripReason

TS = 0.002  # s, the rig's 500 Hz
LIMITS = SafetyLimits(u_max=5.0, slew=500.0, n_bad=10, n_late=3, n_start=1)
OK = {"theta": 0.1, "alpha": 0.01, "theta_dot": 1.0}
FAST = settings(max_examples=150, deadline=None)

volts = st.floats(min_value=-1e3, max_value=1e3) | st.sampled_from([math.nan, math.inf, -math.inf])
angles = st.floats(min_value=-4.0, max_value=4.0) | st.just(math.nan)
samples = st.lists(
    st.tuples(
        angles,  # θ
        st.floats(min_value=-0.4, max_value=0.4),  # α
        st.floats(min_value=-40.0, max_value=40.0),  # θ̇
        volts,
        st.booleans(),  # late
    ),
    min_size=1,
    max_size=200,
)


def feed(sup: Supervisor, rows: list[tuple[float, float, float, float, bool]]) -> list[Decision]:
    return [
        sup.step(k, k * TS, theta, alpha, theta_dot, u, late)
        for k, (theta, alpha, theta_dot, u, late) in enumerate(rows)
    ]


@FAST
@given(samples, st.integers(min_value=1, max_value=12))
def test_the_voltage_and_its_slew_stay_inside_the_limits_and_a_trip_is_for_good(
    rows: list[tuple[float, float, float, float, bool]], n_bad: int
) -> None:
    limits = SafetyLimits(u_max=5.0, slew=500.0, n_bad=n_bad, n_late=3, n_start=1)
    decisions = feed(Supervisor(limits, TS), rows)
    u_prev, tripped = 0.0, False
    for d in decisions:
        assert math.isfinite(d.u_applied) and abs(d.u_applied) <= limits.u_max
        if d.trip is None:
            assert not tripped, "a trip is latched"
            assert abs(d.u_applied - u_prev) <= limits.slew * TS * (1 + 1e-12)
        else:
            tripped = True
            assert d.u_applied == 0.0  # to 0 V at once, whatever the slew
        u_prev = d.u_applied


@FAST
@given(
    st.integers(min_value=2, max_value=15),
    st.lists(st.booleans(), min_size=1, max_size=120),
    st.sampled_from(["theta", "alpha", "theta_dot"]),
)
def test_a_limit_trips_at_exactly_the_nth_bad_sample_in_a_row(
    n_bad: int, bad: list[bool], which: str
) -> None:
    sup = Supervisor(SafetyLimits(n_bad=n_bad), TS)
    run = 0
    for k, is_bad in enumerate(bad):
        measured = {**OK, which: 100.0 if is_bad else OK[which]}  # beyond every limit
        d = sup.step(
            k, k * TS, measured["theta"], measured["alpha"], measured["theta_dot"], 1.0, False
        )
        run = run + 1 if is_bad else 0
        if run < n_bad:
            assert d.trip is None, f"tripped after {run} bad samples in a row, limit {n_bad}"
        else:
            assert d.trip is not None and d.trip.k == k and d.u_applied == 0.0
            return


def step_ok(sup: Supervisor, k: int, u: float = 1.0, late: bool = False) -> Decision:
    return sup.step(k, k * TS, OK["theta"], OK["alpha"], OK["theta_dot"], u, late)


@pytest.mark.parametrize(
    ("which", "value", "reason", "limit", "text"),
    [
        ("theta", 2.2, TripReason.ANGLE, math.radians(120), "θ = 2.2 rad beyond ±2.094 rad"),
        ("theta_dot", -31.0, TripReason.SPEED, 30.0, "θ̇ = -31 rad/s beyond ±30 rad/s"),
        ("alpha", 0.3, TripReason.DEFLECTION, math.radians(15), "α = 0.3 rad beyond ±0.2618"),
        ("alpha", math.nan, TripReason.DEFLECTION, math.radians(15), "α = nan rad"),
    ],
)
def test_each_measured_limit_trips_after_ten_in_a_row_with_its_reason(
    which: str, value: float, reason: TripReason, limit: float, text: str
) -> None:
    sup = Supervisor(SafetyLimits(), TS)
    for k in range(10):
        m = {**OK, which: value}
        d = sup.step(k, k * TS, m["theta"], m["alpha"], m["theta_dot"], 2.0, False)
    assert d.trip is not None and d.u_applied == 0.0
    assert (d.trip.reason, d.trip.k, d.trip.limit) == (reason, 9, limit)
    assert text in d.trip.message and "for 10 samples in a row" in d.trip.message
    assert step_ok(sup, 10) == d  # latched, and the first trip stays the one reported


def test_a_late_answer_holds_the_last_voltage_and_m_in_a_row_trip() -> None:
    sup = Supervisor(LIMITS, TS)
    for k in range(5):
        assert step_ok(sup, k, u=0.4).u_applied == pytest.approx(0.4)
    assert step_ok(sup, 5, u=-3.0, late=True).u_applied == pytest.approx(0.4)  # held
    assert step_ok(sup, 6, u=math.nan).u_applied == pytest.approx(0.4)  # no answer either
    d = step_ok(sup, 7, late=True)
    assert d.trip == Trip(
        TripReason.DEADLINE,
        7,
        7 * TS,
        3.0,
        3.0,
        "the controller missed its deadline 3 samples in a row (limit 3)",
    )


def test_the_voltage_is_clipped_and_slew_limited() -> None:
    sup = Supervisor(LIMITS, TS)  # 500 V/s at 2 ms: 1 V per sample
    assert [step_ok(sup, k, u=100.0).u_applied for k in range(7)] == pytest.approx(
        [1.0, 2.0, 3.0, 4.0, 5.0, 5.0, 5.0]
    )
    assert step_ok(sup, 7, u=-100.0).u_applied == pytest.approx(4.0)


def test_estop_disconnect_and_a_rig_fault_trip_at_once_and_reset_clears() -> None:
    sup = Supervisor(LIMITS, TS)
    step_ok(sup, 0)
    assert sup.estop(1, TS).trip == Trip(
        TripReason.ESTOP, 1, TS, 0.0, 0.0, "emergency stop pressed"
    )
    assert sup.disconnect(2, 2 * TS).trip == sup.trip  # the first trip stays
    sup.reset()
    assert step_ok(sup, 0).trip is None
    d = sup.disconnect(1, TS)
    assert d.trip is not None and d.trip.reason is TripReason.DISCONNECT
    sup.reset()
    d = sup.step(0, 0.0, 0.0, 0.0, 0.0, 1.0, False, fault=True)
    assert d.trip is not None and d.trip.reason is TripReason.RIG_FAULT and d.u_applied == 0.0


def test_inactivity_and_duration_trip_on_the_fed_time() -> None:
    sup = Supervisor(SafetyLimits(inactivity=90.0, duration=600.0), 1.0)
    for k in range(91):
        assert sup.step(k, float(k), 0, 0, 0, 0, False).trip is None
    d = sup.step(91, 91.0, 0, 0, 0, 0, False)
    assert d.trip is not None and d.trip.reason is TripReason.INACTIVITY
    assert d.trip.message == "no command from the user for 91 s (limit 90 s)"
    sup.reset()
    for k in range(0, 601, 60):
        sup.touch(float(k))
        assert sup.step(k, float(k), 0, 0, 0, 0, False).trip is None
    d = sup.step(601, 601.0, 0, 0, 0, 0, False)
    assert d.trip is not None and (d.trip.reason, d.trip.value) == (TripReason.DURATION, 601.0)


@pytest.mark.parametrize(
    ("kw", "text"),
    [
        ({"u_max": 0.0}, "safety.u_max: got 0; allowed: a finite number > 0"),
        ({"slew": math.inf}, "safety.slew: got inf"),
        ({"n_bad": 0}, "safety.n_bad: got 0; allowed: a whole number ≥ 1"),
        ({"n_late": 2.5}, "safety.n_late: got 2.5"),
    ],
)
def test_limits_are_checked_with_the_field_the_value_and_what_is_allowed(
    kw: dict[str, float], text: str
) -> None:
    with pytest.raises(InvalidInput) as e:
        SafetyLimits(**kw)  # type: ignore[arg-type]
    assert text in str(e.value)
    with pytest.raises(InvalidInput, match="Ts"):
        Supervisor(SafetyLimits(), 0.0)


def test_the_flexible_link_defaults() -> None:
    lim = SafetyLimits()
    assert (lim.u_max, lim.n_bad, lim.inactivity) == (10.0, 10, 90.0)  # practable's 10 and 90 s
    assert math.degrees(lim.theta_max) == pytest.approx(120.0)
    assert math.degrees(lim.alpha_max) == pytest.approx(15.0)


def test_late_answers_at_a_runs_start_hold_the_voltage_and_trip_only_after_it() -> None:
    """A fresh controller process answers its first samples slowly: the voltage holds
    (0 V at the start) through ``n_start`` samples; still late after them, it trips."""
    sup = Supervisor(SafetyLimits(n_late=3, n_start=20), 1e-3)
    for k in range(20):
        d = sup.step(k, k * 1e-3, 0.0, 0.0, 0.0, 7.0, True)
        assert d.trip is None and d.u_applied == 0.0
    d = sup.step(20, 0.02, 0.0, 0.0, 0.0, 7.0, True)
    assert d.trip is not None and d.trip.reason is TripReason.DEADLINE and d.trip.k == 20
