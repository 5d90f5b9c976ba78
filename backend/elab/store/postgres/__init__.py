"""The store on PostgreSQL (``ELAB_DATABASE_URL``): the same protocols, the same operations
(:mod:`elab.store.sql`) as the embedded SQLite file, on
:class:`~elab.store.postgres.connections.PostgresConnections` (a pool of psycopg
connections); the schema and its migrations in :mod:`elab.store.postgres.schema`.

Processes and hosts: any number of web nodes and engines open the same database; the
first to migrate it does so under an advisory lock, the rest find it current (engines only
check). Every operation is one transaction; a read sees one committed snapshot.

Faults: a lost connection, a full pool, a serialisation failure leave as a transient
:class:`~elab.store.base.StoreError` (the engine keeps the samples pending and retries, as
for a busy SQLite file); anything else as a lasting one.
"""

from __future__ import annotations

from elab.store.postgres.connections import PostgresConnections
from elab.store.sql.access import Access
from elab.store.sql.library import Library
from elab.store.sql.rig import RigQueues
from elab.store.sql.runs import Runs


class PostgresStore(Runs, Library, Access, RigQueues, PostgresConnections):
    """Runs, parameter changes and samples, uploaded controllers, identified models,
    tokens, pins and the rig queue in one PostgreSQL database."""
