"""What the tables' operations stand on, whichever database holds them: a write transaction
and a read snapshot handing out a :class:`Conn`, and the few places where SQLite and
PostgreSQL speak differently (:class:`Tables`' class attributes and hooks). Each back-end
(:mod:`elab.store.sqlite`, :mod:`elab.store.postgres`) implements them once; the
operations (:mod:`.runs`, :mod:`.library`, :mod:`.access`, :mod:`.rig`) are written once,
in the SQL both speak (``?`` and ``:name`` parameters; ``rowid`` is a column of every
table that orders by arrival)."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator, Sequence
from contextlib import AbstractContextManager
from types import TracebackType
from typing import Any, ClassVar, Protocol, Self

from elab.errors import ElabError, InvalidInput

NEWEST_FIRST = "ORDER BY created_at DESC, rowid DESC"


class Rows(Protocol):
    """A statement's result: its rows and, for a write, how many it changed."""

    @property
    def rowcount(self) -> int: ...

    @property
    def description(self) -> Any: ...

    def fetchone(self) -> Any: ...

    def fetchall(self) -> list[Any]: ...

    def __iter__(self) -> Iterator[Any]: ...


class Conn(Protocol):
    """A connection inside one transaction."""

    def execute(self, sql: str, parameters: Any = ..., /) -> Rows: ...

    def executemany(self, sql: str, parameters: Sequence[Any], /) -> Any: ...


class Tables:
    """The hooks every back-end provides, and what the tables share."""

    #: the error of a broken unique or foreign key (the caller turns it into a Conflict)
    Duplicate: ClassVar[type[Exception]]
    #: appended to a ``SELECT`` whose rows the transaction is about to change
    LOCK_ROWS: ClassVar[str]
    #: the number of a run's channels (``channels``: a JSON array as text)
    CHANNEL_COUNT: ClassVar[str]

    def __init__(self, where: str) -> None:
        self.where = where  # what errors name: the file, or the database without password
        self._channel_counts: dict[str, int] = {}  # live run id → channels (the writer's)
        self.migrated_from: int | None = None  # the schema version found, if it migrated

    def _transaction(self) -> AbstractContextManager[Conn]:
        """One write transaction: committed when the block ends, rolled back if it raises."""
        raise NotImplementedError

    def _snapshot(self) -> AbstractContextManager[Conn]:
        """One read transaction: every query inside sees the same committed state."""
        raise NotImplementedError

    def _serialise(self, conn: Conn, key: str) -> None:
        """Hold off, until this transaction ends, every other transaction that serialises on
        ``key`` (it reads what it is about to write)."""
        raise NotImplementedError

    def _chunk_part(
        self, conn: Conn, chunk: tuple[Any, ...], at: int, size: int
    ) -> tuple[int, bytes]:
        """``(the chunk's length in bytes, size bytes from byte at)`` of the ``chunks`` row
        ``(rowid, run_id, k0)``, without reading the rest of it."""
        raise NotImplementedError

    def claim(self, name: str, wait: float = 10.0) -> None:
        """Hold ``name`` (a process's part: ``web``, an engine's id) in this store until it
        closes or its process dies, even by ``kill -9``: a second claim of it (a second
        server on the same store, whose engine would mark this one's live runs interrupted)
        waits up to ``wait`` s (for a predecessor still ending) and then fails by name."""
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- health ----------------------------------------------------------------
    def probe(self) -> None:
        with self._transaction() as conn:
            conn.execute(
                "INSERT INTO probe (id, at) VALUES (1, ?) "
                "ON CONFLICT (id) DO UPDATE SET at = excluded.at",
                (time.time(),),
            )


def taken(where: str, name: str) -> ElabError:
    return ElabError(
        f"{where}: {name!r} is already running on this store: another E-Lab server uses "
        "the same data (one server per store)"
    )


def text(field: str, value: str) -> str:
    """A text column's value from a user (a name): any text but NUL, which PostgreSQL's text
    cannot hold; refused on both back-ends alike."""
    if "\x00" in value:
        raise InvalidInput(field, value, "text without NUL characters (\\x00)")
    return value


def message(value: str | None) -> str | None:
    """A text column's value the lab wrote (a run's error, which may quote what a user's
    controller raised; why a rig is out of service): NUL written as ``\\x00``, on both
    back-ends alike, so that no message can make a write fail."""
    return None if value is None else value.replace("\x00", "\\x00")


def json_column(field: str, value: dict[str, Any] | list[Any]) -> str:
    try:
        return json.dumps(value, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise InvalidInput(
            field, value, f"JSON-able values: finite numbers, strings, lists, dicts ({e})"
        ) from None
