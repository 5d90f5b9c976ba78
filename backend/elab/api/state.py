"""What the live server holds while it runs, in one typed place: :class:`Lab`, made at
start-up (``create_app``'s lifespan), read by every handler through :func:`lab`."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from starlette.requests import HTTPConnection

if TYPE_CHECKING:  # the modules that make these read the state through lab()
    from elab.api.auth import Authority
    from elab.api.http import Pending, Uploads
    from elab.api.ident import IdentSlots
    from elab.api.settings import Settings
    from elab.jobs import JobPool
    from elab.runs.manager import RunManager
    from elab.runs.prediction import Predictions
    from elab.runs.rigdesk import RigDesk
    from elab.store.base import ControllerStore, ModelStore


@dataclass(frozen=True)
class Lab:
    """The server's parts: its settings and built app (``index``: the app's index.html,
    ``None`` if it was not built), the run manager, the stores of uploaded controllers
    and identified models, who is who (``authority``), the identification workers
    (``jobs``) and the controller trials' (``trials``), and the budgets of requests under
    way: identifications, uploads (and their bodies, ``pending``) and websocket streams,
    each by identity; the rig's queue (``desk``) on a server with a rig."""

    settings: Settings
    index: Path | None
    manager: RunManager
    controllers: ControllerStore
    models: ModelStore
    authority: Authority
    jobs: JobPool
    trials: JobPool
    ident_slots: IdentSlots
    pending: Pending
    uploads: Uploads
    streams: Counter[str]
    predictions: Predictions  # the last runs' predictions made
    desk: RigDesk | None = None  # the rig's queue, on a server with a rig


def lab(conn: HTTPConnection) -> Lab:
    """The server's parts, from any request or websocket."""
    state: Lab = conn.app.state.lab
    return state
