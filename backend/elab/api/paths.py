"""Parameters declared and read once: each path parameter (``{run_id}`` …: an endpoint's
follow from its path), and the ``plant`` filter of a list."""

from __future__ import annotations

import re
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
RUN_ID = Param("run_id", "path", "run id (from POST /runs)", required=True)
MODEL_ID = Param("model_id", "path", "model id (from POST /models)", required=True)
CONTROLLER_ID = Param(
    "controller_id", "path", "controller id (from POST /controllers)", required=True
)
TOKEN_ID = Param("token_id", "path", "token id (from POST /tokens)", required=True)
HELP_PAGE = Param("page", "path", "help page name (from GET /help)", required=True)
PATH_PARAMS = {p.name: p for p in (PLANT_ID, RUN_ID, MODEL_ID, CONTROLLER_ID, TOKEN_ID, HELP_PAGE)}
PLANT_FILTER = Param(
    "plant", "query", "only those of this plant", {"type": "string", "enum": list(PLANTS)}
)


def path_params(path: str) -> tuple[Param, ...]:
    """The parameters of ``path`` (``/runs/{run_id}/data``: ``run_id``), in order."""
    return tuple(PATH_PARAMS[name] for name in re.findall(r"{(\w+)}", path))


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
