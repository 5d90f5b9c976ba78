"""The Starlette application: routes from the endpoint registry, the stream,
the OpenAPI document and its reference page, JSON errors, lifespan."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from pydantic import ValidationError
from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, RedirectResponse, Response
from starlette.routing import BaseRoute, Route, WebSocketRoute

from elab.api import plants, runs  # noqa: F401  (registers their endpoints)
from elab.api.http import ENDPOINTS, error_response
from elab.api.reference import openapi_document, reference_page
from elab.api.settings import Settings
from elab.api.stream import stream
from elab.errors import ElabError
from elab.runs.manager import RunManager
from elab.runs.store import Store

API = "/api/v1"


def create_app(settings: Settings | None = None) -> Starlette:
    settings = settings or Settings.from_env()

    @asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        store = Store(settings.database)
        manager = RunManager(store, max_live=settings.max_live,
                             max_duration=settings.max_duration, tick=settings.tick,
                             flush_interval=settings.flush_interval)
        app.state.manager = manager
        await manager.start()
        try:
            yield
        finally:
            await manager.close()
            store.close()

    doc = openapi_document()
    page = reference_page(doc)

    async def openapi(request: Request) -> Response:
        return JSONResponse(doc)

    async def docs(request: Request) -> Response:
        return HTMLResponse(page)

    async def home(request: Request) -> Response:
        return RedirectResponse(API + "/docs")

    routes: list[BaseRoute] = [Route(API + e.path, e.handler, methods=[e.method])
                               for e in ENDPOINTS]
    routes += [WebSocketRoute(API + "/runs/{run_id}/stream", stream),
               Route(API + "/openapi.json", openapi), Route(API + "/docs", docs),
               Route("/", home)]
    app = Starlette(routes=routes, lifespan=lifespan, exception_handlers={
        ElabError: _error, ValidationError: _error, HTTPException: _http_error})
    app.state.settings = settings
    return app


async def _error(request: Request, exc: Exception) -> Response:
    return error_response(exc)


async def _http_error(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, HTTPException)
    code = {404: "not_found", 405: "invalid"}.get(exc.status_code, "invalid")
    return JSONResponse({"error": {"code": code, "message": f"{exc.detail}: {request.method} "
                                   f"{request.url.path}", "field": None, "errors": []}},
                        status_code=exc.status_code)
