"""The rig queue's rules (pure): seats, arming, runs, slots, no-shows, instructors, service,
and the messages a refused operation gives."""

from __future__ import annotations

import pytest

from elab.errors import Conflict, InvalidInput
from elab.rig_queue import (
    Arm,
    Clear,
    EStop,
    Extend,
    Join,
    Leave,
    Phase,
    QueueChange,
    QueueOp,
    QueuePolicy,
    RigQueue,
    RunEnded,
    SetService,
    Settled,
    Start,
    Stop,
    TakeOver,
    Tick,
    apply,
)

P = QueuePolicy(slot=300.0, grace=60.0)


def run(q: RigQueue, *steps: tuple[float, QueueOp]) -> RigQueue:
    for now, op in steps:
        q = apply(q, op, P, now).queue
    return q


def test_the_first_to_join_is_seated_and_the_next_waits_with_a_place_and_a_wait() -> None:
    q = run(RigQueue(), (0.0, Join("a")), (1.0, Join("b")), (2.0, Join("c")))
    assert q.driver == "a" and q.seat is not None
    assert (q.seat.phase, q.seat.since, q.seat.until) == (Phase.SEATED, 0.0, 300.0)
    assert [q.place(u) for u in "abcz"] == [1, 2, 3, None]
    assert [q.wait(u, P, 100.0) for u in "abcz"] == [0.0, 200.0, 500.0, None]


def test_arm_start_stop_then_the_rig_settles_before_the_next_start() -> None:
    q = run(RigQueue(), (0.0, Join("a")), (5.0, Arm("a")), (6.0, Start("a", "r-1")))
    assert q.seat is not None and (q.seat.phase, q.seat.run_id) == (Phase.RUNNING, "r-1")
    assert q.running == "r-1"
    change = apply(q, Stop("a"), P, 20.0)
    assert change.stop_run == "r-1" and change.queue.settling and change.queue.running is None
    q = run(change.queue, (21.0, Arm("a")))
    with pytest.raises(Conflict, match="settling"):
        apply(q, Start("a", "r-2"), P, 22.0)
    q = run(q, (30.0, Settled()), (31.0, Start("a", "r-2")))
    assert q.seat is not None and q.seat.run_id == "r-2"


def test_a_no_show_loses_its_turn_after_the_grace_and_the_next_is_seated() -> None:
    q = run(RigQueue(), (0.0, Join("a")), (1.0, Join("b")))
    q = run(q, (59.9, Tick()))
    assert q.driver == "a"
    q = run(q, (60.0, Tick()))
    assert (q.users, q.driver) == (("b",), "b")
    assert q.seat is not None and q.seat.until == 360.0


def test_slot_expiry_ends_a_running_turn_and_names_the_run_to_stop() -> None:
    q = run(RigQueue(), (0.0, Join("a")), (1.0, Join("b")), (2.0, Arm("a")), (3.0, Start("a", "r")))
    change = apply(q, Tick(), P, 300.0)
    assert change.stop_run == "r" and change.queue.driver == "b" and change.queue.settling


def test_runs_end_by_the_engine_or_an_e_stop_and_stale_reports_change_nothing() -> None:
    q = run(RigQueue(), (0.0, Join("a")), (1.0, Arm("a")), (2.0, Start("a", "r")))
    assert apply(q, RunEnded("other"), P, 3.0).queue == q
    ended = apply(q, RunEnded("r"), P, 3.0)
    assert ended.stop_run == "r" and ended.queue.seat is not None
    assert ended.queue.seat.phase is Phase.SEATED
    stopped = apply(q, EStop("instructor:prof"), P, 3.0)
    assert stopped.stop_run == "r"
    assert apply(stopped.queue, EStop("a"), P, 4.0).stop_run is None  # never refused


def test_only_the_driver_arms_starts_and_stops() -> None:
    q = run(RigQueue(), (0.0, Join("a")), (1.0, Join("b")))
    with pytest.raises(Conflict, match=r"b: you are not the driver of the rig; your place .* 2"):
        apply(q, Arm("b"), P, 2.0)
    with pytest.raises(Conflict, match="join the queue first"):
        apply(q, Start("z", "r"), P, 2.0)
    with pytest.raises(Conflict, match="arm it before starting"):
        apply(q, Start("a", "r"), P, 2.0)
    with pytest.raises(Conflict, match="nothing to stop"):
        apply(q, Stop("a"), P, 2.0)
    q = run(q, (2.0, Arm("a")))
    with pytest.raises(Conflict, match="already armed"):
        apply(q, Arm("a"), P, 3.0)


def test_join_and_leave_refuse_what_makes_no_sense() -> None:
    q = run(RigQueue(), (0.0, Join("a")))
    with pytest.raises(Conflict, match="already in the rig queue at place 1"):
        apply(q, Join("a"), P, 1.0)
    with pytest.raises(Conflict, match="not in the rig queue"):
        apply(q, Leave("b"), P, 1.0)
    q = run(q, (1.0, Join("b")), (2.0, Arm("a")), (3.0, Start("a", "r")))
    change = apply(q, Leave("a"), P, 4.0)
    assert change.stop_run == "r" and change.queue.driver == "b"


def test_an_instructor_takes_over_and_the_displaced_driver_is_next() -> None:
    q = run(RigQueue(), (0.0, Join("a")), (1.0, Join("b")), (2.0, Arm("a")), (3.0, Start("a", "r")))
    change = apply(q, TakeOver("i"), P, 10.0)
    assert change.stop_run == "r"
    q = change.queue
    assert q.users == ("i", "a", "b") and q.seat is not None and q.seat.took_over
    with pytest.raises(Conflict, match="already drives"):
        apply(q, TakeOver("i"), P, 11.0)
    q = run(q, (11.0, Extend(100.0)))
    assert q.seat is not None and q.seat.until == 410.0
    q = run(q, (12.0, Clear()))
    assert q.users == ("i",)
    with pytest.raises(InvalidInput, match=r"extend.seconds: got -1; allowed: a finite time > 0"):
        apply(q, Extend(-1.0), P, 13.0)


def test_an_out_of_service_rig_seats_nobody_until_it_is_back() -> None:
    q = run(RigQueue(), (0.0, Join("a")), (1.0, Arm("a")), (2.0, Start("a", "r")))
    change = apply(q, SetService("settle timed out"), P, 3.0)
    assert change.stop_run == "r" and change.queue.seat is None
    q = run(change.queue, (4.0, Join("b")))
    assert q.users == ("a", "b") and q.driver is None and q.wait("b", P, 4.0) is None
    for op in (Arm("a"), TakeOver("i")):
        with pytest.raises(Conflict, match=r"out of service \(settle timed out\)"):
            apply(q, op, P, 5.0)
    q = run(q, (6.0, SetService("")))
    assert q.driver == "a" and not q.settling and q.seat is not None and q.seat.since == 6.0


def test_extend_needs_a_driver_and_policies_are_checked() -> None:
    with pytest.raises(Conflict, match="nobody drives"):
        apply(RigQueue(), Extend(10.0), P, 0.0)
    with pytest.raises(InvalidInput, match=r"rig_queue\.slot"):
        QueuePolicy(slot=0.0)
    with pytest.raises(InvalidInput, match=r"rig_queue\.grace: got 400; allowed: at most the slot"):
        QueuePolicy(slot=300.0, grace=400.0)


def test_a_refused_operation_changes_nothing() -> None:
    q = run(RigQueue(), (0.0, Join("a")))
    with pytest.raises(Conflict):
        apply(q, Arm("b"), P, 1.0)
    assert apply(q, Tick(), P, 1.0) == QueueChange(q)


def test_an_instructors_take_over_ends_with_its_seat() -> None:
    q = run(RigQueue(), (0.0, Join("a")), (1.0, TakeOver("i1")), (2.0, TakeOver("i2")))
    assert q.users == ("i2", "a")  # i1 is not queued as a student would be
    q = run(q, (3.0, SetService("encoder fault")), (4.0, SetService("")))
    assert q.users == ("a",) and q.seat is not None and not q.seat.took_over
