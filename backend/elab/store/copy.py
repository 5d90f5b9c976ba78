"""A lab's records moved from the embedded SQLite file into another store: PostgreSQL
(``elab migrate --from FILE``), or another file.

Every table in an order that meets each foreign key, each row with the columns the two
schemas share (they are the same schema version, step for step), in the order the rows
arrived (``rowid``): the destination's own arrival order, and so every "newest first"
list, comes out the same. One read snapshot of the source and one write transaction in
the destination: all or nothing. The source must not be in use (its ``web`` name is
claimed for the copy) and the destination must hold no records."""

from __future__ import annotations

from typing import Any

from elab.errors import Conflict
from elab.store.sql.tables import Conn, Tables
from elab.store.sqlite.connections import SQLiteConnections

#: parents before children (pins, parameter changes and chunks name a run; the seat names
#: its place in the queue, which names its rig); ``probe`` is not copied
TABLES = (
    "runs",
    "param_changes",
    "chunks",
    "pins",
    "tokens",
    "controllers",
    "models",
    "ended_sessions",
    "rigs",
    "rig_queue",
    "rig_seat",
)
#: rows read and written at a time, in the order they arrived (SQLite's ``rowid``: every
#: table of the file has one) (a chunk row holds up to 14 MiB)
BATCH = 64


def copy_records(source: SQLiteConnections, dest: Tables) -> dict[str, int]:
    """Copy every record of the file ``source`` into the empty ``dest``; returns rows per
    table. :class:`Conflict` if ``dest`` holds records; an error naming the file if a
    server is using it."""
    source.claim("web", 0.0)  # a server writing it meanwhile would be missed, or torn
    with source._snapshot() as src, dest._transaction() as dst:
        held = {t: _count(dst, t) for t in ("runs", "controllers", "models", "tokens")}
        if any(held.values()):
            what = ", ".join(f"{n} {t}" for t, n in held.items() if n)
            raise Conflict(f"{dest.where} already holds records ({what}): copy into an empty one")
        copied = {table: _copy(src, dst, table) for table in TABLES}
        for table, n in copied.items():  # what went in is what is there
            if _count(dst, table) != n:
                raise Conflict(f"{dest.where}: {table} holds {_count(dst, table)} rows, not {n}")
    return copied


def _copy(src: Conn, dst: Conn, table: str) -> int:
    described = src.execute(f"SELECT * FROM {table} LIMIT 0").description
    columns = [d[0] for d in described if d[0].lower() != "rowid"]
    names = ", ".join(columns)
    insert = f"INSERT INTO {table} ({names}) VALUES ({', '.join('?' * len(columns))})"
    last, n = -1, 0
    while True:
        rows: list[Any] = src.execute(
            f"SELECT rowid, {names} FROM {table} WHERE rowid > ? ORDER BY rowid LIMIT ?",
            (last, BATCH),
        ).fetchall()
        if not rows:
            return n
        dst.executemany(insert, [tuple(r[1:]) for r in rows])
        last, n = rows[-1][0], n + len(rows)


def _count(conn: Conn, table: str) -> int:
    return int(conn.execute(f"SELECT count(*) FROM {table}").fetchone()[0])
