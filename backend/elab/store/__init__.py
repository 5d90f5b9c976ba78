"""Storage: runs, their parameter changes and their samples, uploaded controllers,
identified models, tokens and pins behind protocols (:class:`RunStore`,
:class:`ControllerStore`, :class:`ModelStore`, :class:`AccessStore`) and the rig queue
(:class:`RigQueueStore`), with SQLite as the embedded implementation and PostgreSQL for
labs on several hosts (:func:`open_store` picks by the target's form)."""

from pathlib import Path
from typing import Protocol

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

#: where a database URL starts (anything else is a SQLite file's path)
POSTGRES_SCHEMES = ("postgresql://", "postgres://")


class Store(RunStore, ControllerStore, ModelStore, AccessStore, RigQueueStore, Protocol):
    """Every part of the store (what :func:`open_store` returns); ``migrated_from``: the
    schema version it found when it migrated on opening (``None``: it did not)."""

    migrated_from: int | None

    def claim(self, name: str, wait: float = 10.0) -> None: ...


def open_store(target: str | Path, *, migrate: bool = True) -> Store:
    """The store at ``target``: a ``postgresql://`` URL (:class:`PostgresStore`, imported
    only then), else the path of a SQLite file (:class:`SQLiteStore`). ``migrate``: bring
    it to this version's schema (web processes, ``elab migrate``), else refuse another
    version (engines)."""
    if isinstance(target, str) and target.startswith(POSTGRES_SCHEMES):
        from elab.store.postgres import PostgresStore

        return PostgresStore(target, migrate=migrate)
    return SQLiteStore(Path(target), migrate=migrate)


__all__ = [
    "POSTGRES_SCHEMES",
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
    "Store",
    "StoreError",
    "StoredController",
    "StoredModel",
    "Token",
    "Usage",
    "open_store",
]
