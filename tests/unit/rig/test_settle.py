"""Between users: settle until still, re-zero, ready; or out of service on a timeout."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from elab.errors import Conflict, InvalidInput
from elab.rig.settle import SettleLimits, SettlePhase, begin_settle, rezeroed, settle_step

L = SettleLimits(theta_dot_still=0.05, alpha_dot_still=0.2, still_for=2.0, timeout=60.0)
TS = 0.01  # s


def test_a_decaying_link_settles_asks_for_a_re_zero_then_is_ready() -> None:
    s = begin_settle(100.0)
    k = 0
    while s.phase is SettlePhase.SETTLING:
        t = 100.0 + k * TS
        # the link's first mode at 0 V: 2 Hz, decaying with a 1 s time constant
        alpha_dot = 3.0 * math.exp(-(t - 100.0)) * math.cos(4 * math.pi * (t - 100.0))
        s = settle_step(s, L, t, 0.0, alpha_dot)
        k += 1
    assert s.phase is SettlePhase.REZERO
    # |α̇| ≤ 0.2 rad/s from about ln(15) = 2.7 s on, then 2 s still
    assert 4.0 < k * TS < 5.0
    assert rezeroed(s).phase is SettlePhase.READY


def test_motion_restarts_the_still_time() -> None:
    s = begin_settle(0.0)
    s = settle_step(s, L, 0.0, 0.0, 0.0)
    s = settle_step(s, L, 1.9, 0.0, 0.0)
    s = settle_step(s, L, 1.95, 0.1, 0.0)  # a bump
    assert s.still_since is None and s.phase is SettlePhase.SETTLING
    s = settle_step(s, L, 2.0, 0.0, 0.0)
    assert settle_step(s, L, 3.99, 0.0, 0.0).phase is SettlePhase.SETTLING
    assert settle_step(s, L, 4.0, 0.0, 0.0).phase is SettlePhase.REZERO


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(min_value=-1.0, max_value=1.0), min_size=1, max_size=80))
def test_a_rig_never_ready_in_time_goes_out_of_service(alpha_dots: list[float]) -> None:
    s = begin_settle(0.0)
    for i, a in enumerate(alpha_dots):  # one sample a second, still or not, never re-zeroed
        s = settle_step(s, L, i * 1.0, 0.0, a)
        assert s.phase is (SettlePhase.OUT_OF_SERVICE if i > 60 else s.phase)
        assert s.phase is not SettlePhase.READY
    s = settle_step(s, L, 60.01, 0.0, 0.0)
    assert s.phase is SettlePhase.OUT_OF_SERVICE
    assert "did not settle and re-zero within 60 s" in s.message
    assert settle_step(s, L, 61.0, 0.0, 0.0) == s  # stays out until an operator acts


def test_re_zero_only_when_asked_and_limits_are_checked() -> None:
    with pytest.raises(Conflict, match="re-zero only when it asks"):
        rezeroed(begin_settle(0.0))
    with pytest.raises(InvalidInput, match=r"settle\.timeout: got 0"):
        SettleLimits(timeout=0.0)
    with pytest.raises(InvalidInput, match=r"settle\.still_for: got 90; allowed: < timeout 60"):
        SettleLimits(still_for=90.0)
