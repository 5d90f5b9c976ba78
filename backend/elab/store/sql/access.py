"""Tokens, ended sessions and pins (the :class:`~elab.store.base.AccessStore` part of
either store)."""

from __future__ import annotations

import time

from elab.errors import NotFound
from elab.store.base import Pin, Token
from elab.store.sql.runs import run_size
from elab.store.sql.tables import Tables, text


class Access(Tables):
    """Tokens, ended sessions and pins."""

    # -- tokens and pins (AccessStore) -------------------------------------------
    def add_token(self, token: Token, digest: str) -> None:
        with self._transaction() as conn:
            conn.execute(
                "INSERT INTO tokens (id, hash, owner, name, created_at, last_used) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (
                    token.id,
                    digest,
                    token.owner,
                    text("name", token.name),
                    token.created_at,
                    token.last_used,
                ),
            )

    def token_by_digest(self, digest: str) -> Token | None:
        with self._snapshot() as conn:
            row = conn.execute(
                "SELECT id, owner, name, created_at, last_used FROM tokens WHERE hash = ?",
                (digest,),
            ).fetchone()
        return Token(*row) if row else None

    def touch_token(self, token_id: str, at: float) -> None:
        with self._transaction() as conn:
            conn.execute("UPDATE tokens SET last_used = ? WHERE id = ?", (at, token_id))

    def tokens(self, owner: str) -> list[Token]:
        with self._snapshot() as conn:
            rows = conn.execute(
                "SELECT id, owner, name, created_at, last_used FROM tokens WHERE owner = ? "
                "ORDER BY created_at",
                (owner,),
            ).fetchall()
        return [Token(*r) for r in rows]

    def revoke_token(self, owner: str, token_id: str) -> None:
        with self._transaction() as conn:
            cur = conn.execute("DELETE FROM tokens WHERE id = ? AND owner = ?", (token_id, owner))
            if cur.rowcount == 0:
                raise NotFound("token", token_id)

    def end_session(self, sid: str, until: float) -> None:
        with self._transaction() as conn:
            conn.execute("DELETE FROM ended_sessions WHERE until < ?", (time.time(),))
            conn.execute(
                "INSERT INTO ended_sessions (sid, until) VALUES (?, ?) "
                "ON CONFLICT (sid) DO UPDATE SET until = excluded.until",
                (sid, until),
            )

    def ended_sessions(self, now: float) -> set[str]:
        with self._snapshot() as conn:
            rows = conn.execute("SELECT sid FROM ended_sessions WHERE until >= ?", (now,))
            return {sid for (sid,) in rows}

    def set_pin(self, pin: Pin) -> None:
        with self._transaction() as conn:
            run_size(conn, pin.run_id)  # NotFound for an unknown run
            conn.execute(
                "INSERT INTO pins (name, run_id, owner, at) VALUES (?, ?, ?, ?) "
                "ON CONFLICT (name) DO UPDATE SET run_id = excluded.run_id, "
                "owner = excluded.owner, at = excluded.at",
                (text("name", pin.name), pin.run_id, pin.owner, pin.at),
            )

    def pin(self, name: str) -> Pin | None:
        with self._snapshot() as conn:
            row = conn.execute(
                "SELECT name, run_id, owner, at FROM pins WHERE name = ?", (name,)
            ).fetchone()
        return Pin(*row) if row else None

    def clear_pin(self, name: str) -> None:
        with self._transaction() as conn:
            conn.execute("DELETE FROM pins WHERE name = ?", (name,))
