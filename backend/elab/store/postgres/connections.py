"""The PostgreSQL side of :class:`~elab.store.sql.tables.Tables`: a pool of connections
(psycopg 3 and psycopg_pool), each operation one transaction on one of them (writes at READ
COMMITTED, taking the rows they are about to change ``FOR UPDATE`` or an advisory lock;
reads one REPEATABLE READ, READ ONLY snapshot), the tables' ``?`` and ``:name`` parameters
as psycopg's, PostgreSQL's errors as :class:`~elab.store.base.StoreError`, and a chunk's
bytes read in place with ``substring``."""

from __future__ import annotations

import re
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from functools import lru_cache, partial
from typing import Any

import psycopg
import psycopg.conninfo
import psycopg.errors
import psycopg_pool

from elab.store.base import StoreError
from elab.store.postgres import schema
from elab.store.sql.tables import Conn, Rows, Tables, taken

#: connections one process keeps at most (a web node's threads, an engine's writer)
POOL_SIZE = 10
#: seconds an operation waits for a free connection, or a new process for the database
POOL_TIMEOUT = 30.0
_LOCK_NOT_AVAILABLE = "55P03"  # a lock not granted within lock_timeout


class PostgresConnections(Tables):
    """A pool of connections to one database, and the transactions the tables' methods
    run in."""

    Duplicate = psycopg.errors.IntegrityError
    LOCK_ROWS = " FOR UPDATE"
    CHANNEL_COUNT = "json_array_length(channels::json)"

    def __init__(
        self,
        url: str,
        *,
        migrate: bool = True,
        timeout: float = POOL_TIMEOUT,
        busy_timeout: float = 5.0,
    ) -> None:
        """Connect to the database at ``url`` (``postgresql://user:password@host:port/db``);
        ``migrate``: bring it to this version's schema (under a lock: any number of
        processes may do so at once), else refuse a database of another version. An
        operation waits ``busy_timeout`` s for a lock another session holds (PostgreSQL's
        ``lock_timeout``), then fails transiently, as a busy SQLite file does."""
        super().__init__(redacted(url))
        self._url = url
        self._claims: dict[str, psycopg.Connection[Any]] = {}  # sessions holding claims
        with _faults(self.where):
            # one connection first, for the schema and for a clear error if the database
            # cannot be reached (the pool would only say it timed out)
            with psycopg.connect(url, autocommit=True, connect_timeout=max(1, round(timeout))) as c:
                if migrate:
                    self.migrated_from = schema.migrate(c, self.where)
                else:
                    schema.check_version(c, self.where)
            self._pool = psycopg_pool.ConnectionPool(
                url,
                min_size=1,
                max_size=POOL_SIZE,
                kwargs={"autocommit": True},  # transactions are explicit blocks
                configure=partial(_configure, lock_timeout=busy_timeout),
                timeout=timeout,
                name="elab-store",
                open=False,
            )
            self._pool.open(wait=True, timeout=timeout)

    def claim(self, name: str, wait: float = 10.0) -> None:
        """A session-level advisory lock on a connection of its own: PostgreSQL lets go
        when the session ends, and a dead process's session ends with its socket. A name
        this store holds already is held."""
        if name in self._claims:
            return
        with _faults(self.where):
            conn = psycopg.connect(self._url, autocommit=True)
            deadline = time.monotonic() + wait
            # advisory locks are the database's; the store is its tables in this schema
            query = "SELECT pg_try_advisory_lock(hashtext(current_schema() || ' ' || %s))"
            while not (conn.execute(query, (f"elab {name}",)).fetchone() or (False,))[0]:
                if time.monotonic() >= deadline:
                    conn.close()
                    raise taken(self.where, name)
                time.sleep(0.05)
        self._claims[name] = conn

    def close(self) -> None:
        self._pool.close()
        while self._claims:
            self._claims.popitem()[1].close()

    @contextmanager
    def _transaction(self) -> Iterator[Conn]:
        with _faults(self.where), self._pool.connection() as raw, raw.transaction():
            yield _Adapted(raw)

    @contextmanager
    def _snapshot(self) -> Iterator[Conn]:
        with _faults(self.where), self._pool.connection() as raw, raw.transaction():
            raw.execute("SET TRANSACTION ISOLATION LEVEL REPEATABLE READ, READ ONLY")
            yield _Adapted(raw)

    def _serialise(self, conn: Conn, key: str) -> None:
        conn.execute("SELECT pg_advisory_xact_lock(hashtext(current_schema() || ' ' || ?))", (key,))

    def _chunk_part(
        self, conn: Conn, chunk: tuple[Any, ...], at: int, size: int
    ) -> tuple[int, bytes]:
        assert isinstance(conn, _Adapted)
        _, run_id, k0 = chunk
        row = conn.raw.execute(
            "SELECT octet_length(data), substring(data FROM %s FOR %s) FROM chunks "
            "WHERE run_id = %s AND k0 = %s",
            (at + 1, size, run_id, k0),
            binary=True,
        ).fetchone()
        return (0, b"") if row is None else (int(row[0]), bytes(row[1]))


def _configure(conn: psycopg.Connection[Any], *, lock_timeout: float) -> None:
    conn.execute(
        "SELECT set_config('lock_timeout', %s, false)", (f"{round(lock_timeout * 1000)}ms",)
    )


class _Adapted:
    """A psycopg connection taking the tables' ``?`` and ``:name`` parameters, and text
    parameters holding NUL, which PostgreSQL's text cannot (it refuses the statement), as
    NULL: no stored text holds NUL (the tables refuse names with one and write it out in
    messages, on both back-ends), so such a key matches nothing — NULL equals nothing —,
    which is what SQLite answers too (a run ``a\\x00b`` is not found, on either)."""

    def __init__(self, raw: psycopg.Connection[Any]) -> None:
        self.raw = raw

    def execute(self, sql: str, parameters: Any = (), /) -> Rows:
        return self.raw.execute(_psycopg_sql(sql), _without_nul(parameters))

    def executemany(self, sql: str, parameters: Sequence[Any], /) -> None:
        with self.raw.cursor() as cur:
            cur.executemany(_psycopg_sql(sql), [_without_nul(p) for p in parameters])


def _without_nul(parameters: Any) -> Any:
    def ok(v: Any) -> Any:
        return None if isinstance(v, str) and "\x00" in v else v

    if isinstance(parameters, dict):
        return {k: ok(v) for k, v in parameters.items()}
    return [ok(v) for v in parameters]


@lru_cache(maxsize=256)
def _psycopg_sql(sql: str) -> str:
    """``?`` → ``%s``, ``:name`` → ``%(name)s`` (a ``::`` cast left alone), ``%`` → ``%%``."""
    sql = sql.replace("%", "%%")
    sql = re.sub(r"(?<![:\w]):([A-Za-z_]\w*)", r"%(\1)s", sql)
    return sql.replace("?", "%s")


def redacted(url: str) -> str:
    """The database as errors and logs name it: no password."""
    try:
        parts = psycopg.conninfo.conninfo_to_dict(url)
    except psycopg.ProgrammingError:
        return "postgresql (an unreadable URL)"
    host, port = parts.get("host") or "localhost", parts.get("port") or 5432
    user, db = str(parts.get("user") or ""), parts.get("dbname") or ""
    return f"postgresql://{user + '@' if user else ''}{host}:{port}/{db}"


@contextmanager
def _faults(where: str) -> Iterator[None]:
    """PostgreSQL's errors as :class:`StoreError`: a lost connection, a full pool, a lock
    held past ``lock_timeout``, a serialisation failure or deadlock (the
    ``OperationalError`` family) are transient; a full disk or out of memory (class 53)
    and everything else are not."""
    try:
        yield
    except psycopg.Error as exc:
        if isinstance(exc, psycopg.errors.IntegrityError | psycopg.ProgrammingError):
            raise  # a bug or a constraint the caller handles, not a fault of the store
        state = exc.sqlstate or ""
        what = "locked by another session: " if state == _LOCK_NOT_AVAILABLE else ""
        transient = isinstance(exc, psycopg.OperationalError) and not state.startswith("53")
        raise StoreError(
            f"{where}: {what}{exc} ({state or type(exc).__name__})", transient=transient
        ) from exc
