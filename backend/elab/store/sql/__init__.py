"""The tables' operations, written once in the SQL that SQLite and PostgreSQL both speak, on
the hooks of :class:`~elab.store.sql.tables.Tables` that each back-end provides."""
