"""The rig queue in the SQLite store under any sequence of operations, time passing and
restarts (a hypothesis state machine): the store always equals the pure rules applied to
the same operations, and never two drivers; the driver is the head of the queue (a student
who joined, or the instructor who took over); places are 1..n without gaps."""

from __future__ import annotations

import shutil
import sqlite3
import tempfile
from pathlib import Path

from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule

from elab.errors import Conflict
from elab.rig_queue import (
    Arm,
    Clear,
    EStop,
    Extend,
    Join,
    Leave,
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
from elab.store import SQLiteStore

STUDENTS = ("a", "b", "c")
INSTRUCTORS = ("i1", "i2")
P = QueuePolicy(slot=300.0, grace=60.0)
RIG = "flexible_link-1"
students = st.sampled_from(STUDENTS)
#: anyone, or "driver": whoever drives now (so that runs start often enough to matter)
anyone = st.sampled_from((*STUDENTS, *INSTRUCTORS, "driver", "driver"))


class RigQueueMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.dir = Path(tempfile.mkdtemp(prefix="elab-rigq-"))
        self.path = self.dir / "s.sqlite3"
        self.store = SQLiteStore(self.path)
        self.raw = sqlite3.connect(self.path)  # the tables as they are, beside the store
        self.model = RigQueue()
        self.now = 1.7e9
        self.runs = 0

    def teardown(self) -> None:
        self.store.close()
        self.raw.close()
        shutil.rmtree(self.dir, ignore_errors=True)

    def who(self, user: str) -> str:
        return (self.model.driver or "a") if user == "driver" else user

    def do(self, op: QueueOp) -> None:
        """Apply ``op`` to the store and to the pure model: both refuse it or both agree."""
        try:
            expected = apply(self.model, op, P, self.now)
        except Conflict:
            expected = None
        try:
            got = self.store.apply_rig(RIG, op, P, self.now)
        except Conflict:
            assert expected is None, f"the store refused {op}, the rules did not"
            return
        assert got == expected
        # the prompt to stop a run agrees with the level the rig engine follows
        assert got.stop_run == (
            self.model.running if got.queue.running != self.model.running else None
        )
        self.model = got.queue

    @rule(user=students)
    def join(self, user: str) -> None:
        self.do(Join(user))

    @rule(user=anyone)
    def leave(self, user: str) -> None:
        self.do(Leave(self.who(user)))

    @rule(user=anyone)
    def arm(self, user: str) -> None:
        self.do(Arm(self.who(user)))

    @rule(user=anyone)
    def start(self, user: str) -> None:
        self.runs += 1
        self.do(Start(self.who(user), f"r-{self.runs}"))

    @rule(user=anyone)
    def stop(self, user: str) -> None:
        self.do(Stop(self.who(user)))

    @rule(user=anyone)
    def estop(self, user: str) -> None:
        self.do(EStop(self.who(user)))

    @rule()
    def run_ends(self) -> None:
        self.do(RunEnded(f"r-{self.runs}"))

    @rule(user=st.sampled_from(INSTRUCTORS))
    def take_over(self, user: str) -> None:
        self.do(TakeOver(user))

    @rule(seconds=st.sampled_from([30.0, 600.0]))
    def extend(self, seconds: float) -> None:
        self.do(Extend(seconds))

    @rule()
    def clear(self) -> None:
        self.do(Clear())

    @rule()
    def settled(self) -> None:
        self.do(Settled())

    @rule(reason=st.sampled_from(["", "settle timed out"]))
    def service(self, reason: str) -> None:
        self.do(SetService(reason))

    @rule(dt=st.sampled_from([0.5, 30.0, 59.9, 60.0, 120.0, 301.0]))
    def time_passes(self, dt: float) -> None:
        self.now += dt
        self.do(Tick())

    @rule()
    def restart(self) -> None:
        self.store.close()
        self.store = SQLiteStore(self.path)
        assert self.store.rig_queue(RIG, P, self.now) == self.model

    @invariant()
    def one_driver_at_the_head_and_places_without_gaps(self) -> None:
        q = self.store.rig_queue(RIG, P, self.now)
        assert q == self.model
        seats = self.raw.execute("SELECT user_id FROM rig_seat WHERE rig = ?", (RIG,)).fetchall()
        places = self.raw.execute(
            "SELECT place, user_id FROM rig_queue WHERE rig = ? ORDER BY place", (RIG,)
        ).fetchall()
        assert len(seats) <= 1  # never two drivers
        assert [p for p, _ in places] == list(range(1, len(places) + 1))
        assert tuple(u for _, u in places) == q.users and len(set(q.users)) == len(q.users)
        if q.seat is not None:
            assert seats == [(q.seat.user,)] and q.users[0] == q.seat.user
            assert (q.seat.user in INSTRUCTORS) == q.seat.took_over
            assert not q.out_of_service
        for user in q.users:
            wait = q.wait(user, P, self.now)
            assert wait is None or wait >= 0


RigQueueMachine.TestCase.settings = settings(max_examples=40, stateful_step_count=30, deadline=None)
test_rig_queue_machine = RigQueueMachine.TestCase
