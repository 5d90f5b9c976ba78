"""The embedded store (:class:`~elab.store.base.RunStore` and the other protocols of
:mod:`elab.store.base`): one SQLite file.

The tables' operations (:mod:`elab.store.sql`: runs, parameter changes and samples;
uploaded controllers and identified models; tokens, ended sessions and pins; the rig queue)
on :class:`~elab.store.sqlite.connections.SQLiteConnections` (the file's connections,
transactions and faults); the schema and its migrations in :mod:`elab.store._db`.

Durability: WAL journal, ``synchronous = NORMAL``. Every committed transaction
survives a crash of the process (``kill -9``); a power cut may lose the last
transactions, never the file's consistency (see :mod:`elab.store._db`).

Processes: the web process opens the file first and migrates it; engines open it
after (``migrate=False``) and write their runs; anyone reads. Threads: one
connection for writes and one for reads, each behind its own lock, so a reader
sees the last committed state while a writer appends.

Faults: every :class:`sqlite3.Error` leaves as a
:class:`~elab.store.base.StoreError`; a busy or locked database (another writer
past the busy timeout) is transient, anything else (full, read-only, I/O error,
damaged file) is not.
"""

from __future__ import annotations

from elab.store.sql.access import Access
from elab.store.sql.library import Library
from elab.store.sql.rig import RigQueues
from elab.store.sql.runs import Runs
from elab.store.sqlite.connections import SQLiteConnections


class SQLiteStore(Runs, Library, Access, RigQueues, SQLiteConnections):
    """Runs, parameter changes and samples, uploaded controllers, identified models,
    tokens, pins and the rig queue in one SQLite file (WAL mode)."""
