"""Storage: runs, their parameter changes and their samples, uploaded controllers,
identified models, tokens and pins behind protocols (:class:`RunStore`,
:class:`ControllerStore`, :class:`ModelStore`, :class:`AccessStore`) and the rig queue
(:class:`RigQueueStore`), with SQLite as the embedded implementation."""

from elab.store.base import (
    AccessStore,
    ControllerStore,
    ModelStore,
    ParamChange,
    Pin,
    RigQueueStore,
    RunRecord,
    RunStore,
    RunSummary,
    StoredController,
    StoredModel,
    StoreError,
    Token,
    Usage,
)
from elab.store.sqlite import SQLiteStore

__all__ = [
    "AccessStore",
    "ControllerStore",
    "ModelStore",
    "ParamChange",
    "Pin",
    "RigQueueStore",
    "RunRecord",
    "RunStore",
    "RunSummary",
    "SQLiteStore",
    "StoreError",
    "StoredController",
    "StoredModel",
    "Token",
    "Usage",
]
