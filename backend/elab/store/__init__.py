"""Storage: runs, their parameter changes and their samples behind one protocol
(:class:`RunStore`), with SQLite as the embedded implementation."""

from elab.store.base import (
    AccessStore,
    ControllerStore,
    ParamChange,
    Pin,
    RunRecord,
    RunStore,
    RunSummary,
    StoredController,
    StoreError,
    Token,
    Usage,
)
from elab.store.sqlite import SQLiteStore

__all__ = [
    "AccessStore",
    "ControllerStore",
    "ParamChange",
    "Pin",
    "RunRecord",
    "RunStore",
    "RunSummary",
    "SQLiteStore",
    "StoreError",
    "StoredController",
    "Token",
    "Usage",
]
