"""Storage: runs, their parameter changes and their samples behind one protocol
(:class:`RunStore`), with SQLite as the embedded implementation."""

from elab.store.base import (
    AccessStore,
    ParamChange,
    Pin,
    RunRecord,
    RunStore,
    RunSummary,
    StoreError,
    Token,
    Usage,
)
from elab.store.sqlite import SQLiteStore

__all__ = [
    "AccessStore",
    "ParamChange",
    "Pin",
    "RunRecord",
    "RunStore",
    "RunSummary",
    "SQLiteStore",
    "StoreError",
    "Token",
    "Usage",
]
