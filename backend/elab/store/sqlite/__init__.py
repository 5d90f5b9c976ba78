"""The embedded store (:class:`~elab.store.base.RunStore` and the other protocols of
:mod:`elab.store.base`): one SQLite file.

One class per group of tables, all on :class:`~elab.store.sqlite.connections.SQLiteConnections`
(the connections, transactions and faults): :mod:`~elab.store.sqlite.runs` (runs,
parameter changes, samples), :mod:`~elab.store.sqlite.library` (uploaded controllers,
identified models), :mod:`~elab.store.sqlite.access` (tokens, ended sessions, pins),
:mod:`~elab.store.sqlite.rig` (the rig queue);
:class:`SQLiteStore` is all of them.

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

from elab.store.sqlite.access import SQLiteAccess
from elab.store.sqlite.library import SQLiteLibrary
from elab.store.sqlite.rig import SQLiteRigQueue
from elab.store.sqlite.runs import SQLiteRuns


class SQLiteStore(SQLiteRuns, SQLiteLibrary, SQLiteAccess, SQLiteRigQueue):
    """Runs, parameter changes and samples, uploaded controllers, identified models,
    tokens, pins and the rig queue in one SQLite file (WAL mode)."""
