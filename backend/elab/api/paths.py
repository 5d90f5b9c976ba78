"""Parameters several resources share, declared and read once: a plant's id in the path
(``{plant_id}``) and the ``plant`` filter of a list."""

from __future__ import annotations

from typing import TypeVar

from starlette.requests import HTTPConnection, Request

from elab.api import schemas as s
from elab.api.http import Param, query, read_model
from elab.errors import InvalidInput
from elab.plants import PLANTS, Plant, get_plant

M = TypeVar("M", bound=s.Model)
PLANT_ID = Param(
    "plant_id",
    "path",
    "plant id: " + ", ".join(PLANTS),
    {"type": "string", "enum": list(PLANTS)},
    required=True,
)
PLANT_FILTER = Param(
    "plant", "query", "only those of this plant", {"type": "string", "enum": list(PLANTS)}
)


def plant_of(request: Request) -> Plant:
    """The plant the path names (``{plant_id}``; 404 for an unknown one)."""
    return get_plant(request.path_params["plant_id"])


async def plant_and_body(request: Request, model: type[M]) -> tuple[Plant, M]:
    """The path's plant (404 first, whatever the body) and the body as ``model``."""
    plant = plant_of(request)
    return plant, await read_model(request, model)


def plant_filter(request: HTTPConnection) -> str | None:
    """The ``plant`` query parameter of a list (:data:`PLANT_FILTER`): a plant's id, or
    ``None`` for every plant."""
    plant = query(request, "plant")
    if plant is not None and plant not in PLANTS:
        raise InvalidInput("plant", plant, "one of " + ", ".join(PLANTS))
    return plant
