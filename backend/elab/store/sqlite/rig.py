"""The rig queue in SQLite (the :class:`~elab.store.base.RigQueueStore` part of
:class:`~elab.store.sqlite.SQLiteStore`).

An operation is one ``BEGIN IMMEDIATE`` transaction: it takes SQLite's write lock before
reading, so no other thread or process can read the queue between this one's read and its
write; the pure rule (:func:`elab.rig_queue.apply`) decides in between. The tables say
the same again (migration 8): one seat row per rig, and that row must be the user at
place 1 of the queue (a deferred foreign key), so even a faulty writer cannot store two
drivers.
"""

from __future__ import annotations

import sqlite3

from elab.rig_queue import Phase, QueueChange, QueueOp, QueuePolicy, RigQueue, Seat, Tick, apply
from elab.store.sqlite.connections import SQLiteConnections


class SQLiteRigQueue(SQLiteConnections):
    """The queue, the seat and the service state of each rig."""

    def rig_queue(self, rig: str, policy: QueuePolicy, now: float) -> RigQueue:
        with self._snapshot() as conn:
            stored = read_queue(conn, rig)
        if apply(stored, Tick(), policy, now).queue == stored:
            return stored  # time changed nothing: no write needed
        return self.apply_rig(rig, Tick(), policy, now).queue

    def apply_rig(self, rig: str, op: QueueOp, policy: QueuePolicy, now: float) -> QueueChange:
        with self._transaction() as conn:
            stored = read_queue(conn, rig)
            change = apply(stored, op, policy, now)  # Conflict: rolled back, nothing written
            if change.queue != stored:
                write_queue(conn, rig, change.queue, now)
        return change


def read_queue(conn: sqlite3.Connection, rig: str) -> RigQueue:
    state = conn.execute(
        "SELECT settling, out_of_service FROM rigs WHERE rig = ?", (rig,)
    ).fetchone()
    if state is None:
        return RigQueue()
    users = conn.execute(
        "SELECT user_id FROM rig_queue WHERE rig = ? ORDER BY place", (rig,)
    ).fetchall()
    row = conn.execute(
        "SELECT user_id, phase, since, until, run_id, took_over FROM rig_seat WHERE rig = ?",
        (rig,),
    ).fetchone()
    seat = None
    if row is not None:
        user, phase, since, until, run_id, took_over = row
        seat = Seat(user, Phase(phase), since, until, run_id, bool(took_over))
    return RigQueue(tuple(u for (u,) in users), seat, bool(state[0]), state[1])


def write_queue(conn: sqlite3.Connection, rig: str, q: RigQueue, now: float) -> None:
    """Replace what the store holds of ``rig`` by ``q`` (inside the caller's transaction)."""
    conn.execute(
        "INSERT OR REPLACE INTO rigs (rig, settling, out_of_service, updated_at) "
        "VALUES (?, ?, ?, ?)",
        (rig, int(q.settling), q.out_of_service, now),
    )
    conn.execute("DELETE FROM rig_seat WHERE rig = ?", (rig,))
    conn.execute("DELETE FROM rig_queue WHERE rig = ?", (rig,))
    conn.executemany(
        "INSERT INTO rig_queue (rig, place, user_id) VALUES (?, ?, ?)",
        [(rig, place, user) for place, user in enumerate(q.users, start=1)],
    )
    if q.seat is not None:
        s = q.seat
        conn.execute(
            "INSERT INTO rig_seat (rig, user_id, phase, since, until, run_id, took_over) "
            "VALUES (?, ?, ?, ?, ?, ?, ?)",
            (rig, s.user, s.phase.value, s.since, s.until, s.run_id, int(s.took_over)),
        )
