"""The rig queue (the :class:`~elab.store.base.RigQueueStore` part of either store).

An operation is one transaction serialised on its rig before it reads (SQLite: its
``BEGIN IMMEDIATE`` write lock; PostgreSQL: an advisory lock on the rig's name), so no
other thread, process or host can read the queue between this one's read and its write;
the pure rule (:func:`elab.rig_queue.apply`) decides in between. The tables say the same
again (migration 8): one seat row per rig, and that row must be the user at
place 1 of the queue (a deferred foreign key), so even a faulty writer cannot store two
drivers.
"""

from __future__ import annotations

from elab.rig_queue import Phase, QueueChange, QueueOp, QueuePolicy, RigQueue, Seat, Tick, apply
from elab.store.sql.tables import Conn, Tables, message


class RigQueues(Tables):
    """The queue, the seat and the service state of each rig."""

    def rig_queue(self, rig: str, policy: QueuePolicy, now: float) -> RigQueue:
        with self._snapshot() as conn:
            stored = read_queue(conn, rig)
        if apply(stored, Tick(), policy, now).queue == stored:
            return stored  # time changed nothing: no write needed
        return self.apply_rig(rig, Tick(), policy, now).queue

    def apply_rig(self, rig: str, op: QueueOp, policy: QueuePolicy, now: float) -> QueueChange:
        with self._transaction() as conn:
            self._serialise(conn, f"rig {rig}")
            stored = read_queue(conn, rig)
            change = apply(stored, op, policy, now)  # Conflict: rolled back, nothing written
            if change.queue != stored:
                write_queue(conn, rig, change.queue, now)
        return change


def read_queue(conn: Conn, rig: str) -> RigQueue:
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


def write_queue(conn: Conn, rig: str, q: RigQueue, now: float) -> None:
    """Replace what the store holds of ``rig`` by ``q`` (inside the caller's transaction)."""
    conn.execute(
        "INSERT INTO rigs (rig, settling, out_of_service, updated_at) VALUES (?, ?, ?, ?) "
        "ON CONFLICT (rig) DO UPDATE SET settling = excluded.settling, "
        "out_of_service = excluded.out_of_service, updated_at = excluded.updated_at",
        (rig, int(q.settling), message(q.out_of_service), now),
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
