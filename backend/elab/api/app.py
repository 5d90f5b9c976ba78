"""The Starlette application: routes from the endpoint registry, the stream,
the OpenAPI document and its reference page, JSON errors, lifespan."""

from __future__ import annotations

import asyncio
import gc
import importlib
import logging
from collections import Counter
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from pydantic import ValidationError
from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.requests import ClientDisconnect, Request
from starlette.responses import FileResponse, HTMLResponse, JSONResponse, RedirectResponse, Response
from starlette.routing import BaseRoute, Mount, Route, WebSocketRoute

from elab.api import (  # noqa: F401  (registers their endpoints)
    access,
    controllers,
    designs,
    downloads,
    helpdocs,
    ident,
    models,
    plants,
    prediction,
    rig,
    runs,
)
from elab.api.assets import Assets
from elab.api.auth import Authority, Identify, load_secret, read_instructors
from elab.api.frames import MsgpackCodec
from elab.api.guard import Guard
from elab.api.http import (
    ENDPOINTS,
    GZIP_LEVEL,
    BodyTimeout,
    GZip,
    Handler,
    Pending,
    Uploads,
    error_response,
)
from elab.api.reference import openapi_document, reference_page
from elab.api.settings import Settings
from elab.api.state import Lab, lab
from elab.api.stream import RawSend, Stream
from elab.engines.base import Engine
from elab.engines.emulated import EmulatorProcess
from elab.engines.process import ProcessEngine
from elab.engines.settings import RigSettings
from elab.errors import ElabError
from elab.jobs import JobPool, Names
from elab.rig.estop import estop_address
from elab.runs.manager import RunManager
from elab.runs.patrol import SharedPresence
from elab.runs.prediction import Predictions
from elab.runs.rigdesk import RigDesk
from elab.store import open_store

log = logging.getLogger(__name__)

API = "/api/v1"
#: The built browser app (``make install`` runs the frontend build into it).
STATIC = Path(__file__).parent / "static"
#: The app's own pages: each is answered with index.html and routed in the browser.
APP_PAGES = (
    "/",
    "/plants/{rest:path}",
    "/runs",
    "/runs/{rest:path}",
    "/account",
    "/help",
    "/help/{rest:path}",
    "/compare",
)


async def _simulation_engines(settings: Settings) -> Engine:
    """The engine process this server starts, or the engines on the broker."""
    if settings.redis_url is None:
        return ProcessEngine(
            "sim-0",
            settings.store,
            settings.engine,
            nice=settings.engine_nice,
            max_queue=settings.engine_queue,
            command_timeout=settings.engine_timeout,
            stall_timeout=settings.engine_stall,
        )
    # off the event loop: redis-py's import (only a server on a broker needs it)
    broker = await asyncio.to_thread(importlib.import_module, "elab.engines.broker")
    engines: Engine = broker.BrokerEngines(
        "simulation",
        settings.redis_url,
        command_timeout=settings.engine_timeout,
        stall_timeout=settings.engine_stall,
    )
    return engines


def _presence(engines: Engine) -> SharedPresence | None:
    """Owners' presence shared with the other web processes on the broker, if any."""
    make = getattr(engines, "presence", None)  # BrokerEngines'
    return None if make is None else make()


def create_app(settings: Settings | None = None) -> Starlette:
    settings = settings or Settings.from_env()

    @asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        # migrated here, before the engine opens it
        store = await asyncio.to_thread(open_store, settings.store)
        # one server per store: a second one stops here, before its engine could mark this
        # one's live runs interrupted (its predecessor on a restart has 5 s to let go). On
        # a broker the engines are their own: any number of web processes share the store
        if settings.redis_url is None:
            try:
                await asyncio.to_thread(store.claim, "web", 5.0)
            except BaseException:
                store.close()
                raise
        engines: dict[str, Engine] = {"simulation": await _simulation_engines(settings)}
        emulator = (
            # the emulator's clock above the host loop, as hardware's own would be
            EmulatorProcess(
                settings.rig_seed,
                settings.rig_watchdog,
                min(99, settings.engine.realtime + 2) if settings.engine.realtime else 0,
            )
            if settings.rig == "emulator"
            else None
        )
        keeping = None  # the task that starts a dead emulator again
        desk = None
        if settings.rig != "none":
            address = settings.rig
            if emulator is not None:
                address = await asyncio.to_thread(emulator.start)
                keeping = asyncio.get_running_loop().create_task(emulator.keep())
            engines["rig"] = ProcessEngine(
                "rig-0",
                settings.store,
                RigSettings(
                    address=address,
                    # ahead of the simulation's stepping thread (at ELAB_ENGINE_REALTIME),
                    # which a burst of simulations keeps busy: the rig's watchdog waits
                    # for nobody
                    realtime=min(98, settings.engine.realtime + 1)
                    if settings.engine.realtime
                    else 0,
                    slot=settings.rig_queue.slot,
                    grace=settings.rig_queue.grace,
                    estop=estop_address(settings.data_dir),
                    code_deadline=settings.engine.code_deadline,
                ),
                command_timeout=settings.engine_timeout,
                stall_timeout=settings.engine_stall,
            )
        jobs = JobPool(
            workers=settings.ident_workers,
            timeout=settings.ident_timeout,
            wait=settings.ident_wait,
            preload=ident.JOB_MODULES,
        )
        trials = JobPool(
            workers=settings.trial_workers,
            timeout=settings.trial_timeout,
            wait=settings.ident_wait,
            names=Names(
                "controller trial",
                "ELAB_TRIAL_WORKERS",
                "ELAB_TRIAL_TIMEOUT",
                "ELAB_IDENT_WAIT",
                "a controller whose step computes faster (a trial runs it tens of thousands "
                "of times) or a shorter run; on a loaded server, try again",
            ),
            preload=controllers.JOB_MODULES,
        )
        if "rig" in engines:
            desk = RigDesk(
                store, "rig", settings.rig_queue, estop_address(settings.data_dir), trials
            )
        manager = RunManager(
            store,
            engines,
            MsgpackCodec(),
            limits=settings.limits,
            desk=desk,
            presence=_presence(engines["simulation"]),
        )
        app.state.lab = Lab(
            settings=settings,
            index=STATIC / "index.html" if (STATIC / "index.html").is_file() else None,
            manager=manager,
            controllers=store,
            models=store,
            authority=Authority(
                load_secret(settings.secret, settings.data_dir),
                store,
                read_instructors(settings.instructors),
                session_s=settings.session_hours * 3600.0,
                secure=settings.secure_cookies,
            ),
            jobs=jobs,
            trials=trials,
            ident_slots=ident.IdentSlots(settings.max_ident_per_identity),
            pending=Pending(),
            uploads=Uploads(settings.max_uploads, settings.max_uploads_per_identity),
            streams=Counter(),  # websocket streams open, by identity
            desk=desk,
            predictions=Predictions(),
        )
        # Everything imported so far (numpy, scipy, control, numba: ~160,000 objects) lives
        # as long as the process. Frozen, the collector stops scanning it: a full collection
        # held the GIL for ~110 ms on a slow host, stalling every stream at once.
        gc.collect()
        gc.freeze()
        await jobs.start()  # the workers import while the engine starts
        await trials.start()
        await manager.start()
        try:
            yield
        finally:
            await jobs.close()
            await trials.close()
            await manager.close()
            if keeping is not None:
                keeping.cancel()
                await asyncio.gather(keeping, return_exceptions=True)
            if emulator is not None:
                emulator.close()
            store.close()

    # the OpenAPI document and its page, made on a thread when first asked for: pydantic's
    # JSON Schemas of every model are 0.2 s that start-up need not wait for
    reference: asyncio.Task[tuple[dict[str, Any], str]] | None = None

    def make_reference() -> tuple[dict[str, Any], str]:
        doc = openapi_document()
        return doc, reference_page(doc)

    async def made_reference() -> tuple[dict[str, Any], str]:
        nonlocal reference
        if reference is None:
            reference = asyncio.create_task(asyncio.to_thread(make_reference))
        return await asyncio.shield(reference)

    async def openapi(request: Request) -> Response:
        return JSONResponse((await made_reference())[0])

    async def docs(request: Request) -> Response:
        return HTMLResponse((await made_reference())[1])

    routes: list[BaseRoute] = _endpoint_routes()
    routes += [
        WebSocketRoute(API + "/runs/{run_id}/stream", Stream()),
        Route(API + "/openapi.json", openapi),
        Route(API + "/docs", docs),
    ]
    routes += _app_routes(STATIC)
    app = Starlette(
        routes=routes,
        lifespan=lifespan,
        middleware=[
            Middleware(RawSend),
            Middleware(Guard, hosts=settings.hosts, origins=settings.origins),
            Middleware(Identify),
            Middleware(BodyTimeout, seconds=settings.body_timeout),
            Middleware(GZip, minimum_size=4096, compresslevel=GZIP_LEVEL),
        ],
        exception_handlers={
            ElabError: _error,
            ValidationError: _error,
            HTTPException: _http_error,
            ClientDisconnect: _gone,
        },
    )
    return app


def _endpoint_routes() -> list[BaseRoute]:
    """One route per path, dispatching on the method: a path's 405 then lists in ``Allow``
    every method it takes (a route per method matched only its own)."""
    by_path: dict[str, dict[str, Handler]] = {}
    for e in ENDPOINTS:
        by_path.setdefault(e.path, {})[e.method] = e.handler

    def route(path: str, handlers: dict[str, Handler]) -> Route:
        async def dispatch(request: Request) -> Response:
            return await handlers[request.method](request)

        return Route(API + path, dispatch, methods=list(handlers), name=path)

    return [route(path, handlers) for path, handlers in by_path.items()]


def _app_routes(static: Path) -> list[BaseRoute]:
    """The browser app's pages and assets; without a build, / shows the API reference."""
    index = static / "index.html"
    if not index.is_file():

        async def reference(request: Request) -> Response:
            return RedirectResponse(API + "/docs")

        return [Route("/", reference)]

    async def page(request: Request) -> Response:
        return FileResponse(index, headers={"cache-control": "no-cache"})

    assets = Assets(directory=static / "assets", check_dir=False)
    return [Mount("/assets", assets), *(Route(path, page) for path in APP_PAGES)]


async def _error(request: Request, exc: Exception) -> Response:
    return error_response(exc)


async def _gone(request: Request, exc: Exception) -> Response:
    """The client went away while sending its body: nobody to answer, nothing to fix here
    (it was logged as an exception in the ASGI application, with its traceback)."""
    log.info("%s %s: the client left before its body was in", request.method, request.url.path)
    return Response(status_code=400)


async def _http_error(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, HTTPException)
    index = lab(request).index
    if (
        exc.status_code == 404
        and index is not None
        and request.method in ("GET", "HEAD")
        and not request.url.path.startswith(API + "/")
        and "text/html" in request.headers.get("accept", "")
    ):  # a browser at an unknown address: the app, which says "Page not found"
        return FileResponse(index, status_code=404, headers={"cache-control": "no-cache"})
    code = {404: "not_found", 405: "invalid"}.get(exc.status_code, "invalid")
    return JSONResponse(
        {
            "error": {
                "code": code,
                "message": f"{exc.detail}: {request.method} {request.url.path}",
                "field": None,
                "errors": [],
            }
        },
        status_code=exc.status_code,
        headers=exc.headers,  # Allow: on a 405, the methods the path takes (RFC 9110)
    )
