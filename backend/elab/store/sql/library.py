"""Uploaded controllers and identified models (the :class:`~elab.store.base.ControllerStore`
and :class:`~elab.store.base.ModelStore` parts of either store)."""

from __future__ import annotations

import json
from typing import Any

from elab.errors import Conflict, NotFound
from elab.store.base import StoredController, StoredModel
from elab.store.sql.tables import NEWEST_FIRST, Tables, json_column, text

_CONTROLLER = "id, owner, plant, name, format, law, report, created_at"
_MODEL = "id, owner, plant, name, model, created_at"


class Library(Tables):
    """Uploaded controllers and identified models."""

    # -- uploaded controllers (ControllerStore) ------------------------------------
    def add_controller(self, controller: StoredController) -> None:
        c = controller
        with self._transaction() as conn:
            conn.execute(
                "INSERT INTO controllers (id, owner, plant, name, format, law, report, "
                "source, created_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    c.id,
                    c.owner,
                    c.plant,
                    text("name", c.name),
                    text("format", c.format),
                    json_column("law", c.law),
                    json_column("report", c.report),
                    c.source,
                    c.created_at,
                ),
            )

    def get_controller(self, controller_id: str) -> StoredController:
        with self._snapshot() as conn:
            row = conn.execute(
                f"SELECT {_CONTROLLER}, source FROM controllers WHERE id = ?", (controller_id,)
            ).fetchone()
        if row is None:
            raise NotFound("controller", controller_id)
        return _controller(row[:-1], bytes(row[-1]))

    def list_controllers(
        self, owner: str | None, plant: str | None = None
    ) -> list[StoredController]:
        return [_controller(r) for r in self._owned("controllers", _CONTROLLER, owner, plant)]

    def count_controllers(self, owner: str) -> int:
        return self._count("controllers", owner)

    def delete_controller(self, controller_id: str) -> None:
        self._delete("controllers", "controller", controller_id)

    # -- identified models (ModelStore) -------------------------------------------
    def add_model(self, model: StoredModel) -> None:
        m = model
        row = (
            m.id,
            m.owner,
            m.plant,
            text("name", m.name),
            json_column("model", m.model),
            m.created_at,
        )
        with self._transaction() as conn:
            try:
                conn.execute(f"INSERT INTO models ({_MODEL}) VALUES (?, ?, ?, ?, ?, ?)", row)
            except self.Duplicate:
                raise Conflict(f"model {m.id!r} already exists; choose another id") from None

    def get_model(self, model_id: str) -> StoredModel:
        with self._snapshot() as conn:
            row = conn.execute(f"SELECT {_MODEL} FROM models WHERE id = ?", (model_id,)).fetchone()
        if row is None:
            raise NotFound("model", model_id)
        return _model(row)

    def list_models(self, owner: str | None, plant: str | None = None) -> list[StoredModel]:
        return [_model(r) for r in self._owned("models", _MODEL, owner, plant)]

    def count_models(self, owner: str) -> int:
        return self._count("models", owner)

    def delete_model(self, model_id: str) -> None:
        self._delete("models", "model", model_id)

    # -- either table ----------------------------------------------------------------
    def _owned(
        self, table: str, columns: str, owner: str | None, plant: str | None
    ) -> list[tuple[Any, ...]]:
        """Rows of ``owner`` for ``plant`` (``None``: anyone's, any plant's), newest first,
        at most 1000."""
        given = [("owner = ?", owner), ("plant = ?", plant)]
        terms = [term for term, value in given if value is not None]
        where = "WHERE " + " AND ".join(terms) if terms else ""
        with self._snapshot() as conn:
            return conn.execute(
                f"SELECT {columns} FROM {table} {where} {NEWEST_FIRST} LIMIT 1000",
                [value for _, value in given if value is not None],
            ).fetchall()

    def _count(self, table: str, owner: str) -> int:
        with self._snapshot() as conn:
            n = conn.execute(f"SELECT count(*) FROM {table} WHERE owner = ?", (owner,))
            return int(n.fetchone()[0])

    def _delete(self, table: str, kind: str, item_id: str) -> None:
        with self._transaction() as conn:
            if conn.execute(f"DELETE FROM {table} WHERE id = ?", (item_id,)).rowcount == 0:
                raise NotFound(kind, item_id)


def _controller(row: tuple[Any, ...], source: bytes = b"") -> StoredController:
    id_, owner, plant, name, fmt, law, report, created_at = row
    return StoredController(
        id_, owner, plant, name, fmt, json.loads(law), json.loads(report), created_at, source
    )


def _model(row: tuple[Any, ...]) -> StoredModel:
    id_, owner, plant, name, model, created_at = row
    return StoredModel(id_, owner, plant, name, json.loads(model), created_at)
