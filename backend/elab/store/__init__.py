"""Storage: runs, their parameter changes and their samples behind one protocol
(:class:`RunStore`), with SQLite as the embedded implementation."""

from elab.store.base import ParamChange, RunRecord, RunStore, RunSummary, StoreError
from elab.store.sqlite import SQLiteStore

__all__ = ["ParamChange", "RunRecord", "RunStore", "RunSummary", "SQLiteStore", "StoreError"]
