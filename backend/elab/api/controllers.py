"""Uploaded controllers: templates, upload with the report, list, get, delete, and the law
of one for a run (``POST /runs`` with ``controller_id``). docs/controllers.md.

A controller belongs to whoever uploaded it: only they (and instructors) see, use or
delete it. A file that cannot be read stores nothing.
"""

from __future__ import annotations

import asyncio
import base64
import binascii
import math
import secrets
import time
from collections.abc import AsyncGenerator
from typing import Any

from starlette.datastructures import UploadFile
from starlette.formparsers import MultiPartException, MultiPartParser
from starlette.requests import HTTPConnection, Request
from starlette.responses import Response

from elab import controllers as ctl
from elab.access import Identity, display_name, may_control
from elab.api import convert, preload
from elab.api import schemas as s
from elab.api.auth import identity
from elab.api.http import Param, endpoint, ok, query, read_body, read_model, within_budget
from elab.api.paths import PLANT_FILTER, plant_filter, plant_of
from elab.api.state import lab
from elab.engines.settings import CodeSettings
from elab.errors import InvalidInput, NotFound
from elab.laws import CodeController, ControlLaw, is_code
from elab.plants import PLANTS, get_plant
from elab.store.base import ControllerStore, StoredController

#: what the trial workers import once (their fork server)
JOB_MODULES = preload.TRIALS

MEDIA = {
    "toml": "application/toml",
    "json": "application/json",
    "mat": "application/x-matlab-data",
    "npz": "application/zip",
    "py": "text/x-python",
}


def store(conn: HTTPConnection) -> ControllerStore:
    return lab(conn).controllers


@endpoint(
    "GET",
    "/plants/{plant_id}/controller-template",
    response="file",
    files=tuple(dict.fromkeys(MEDIA.values())),
    params=(
        Param(
            "format",
            "query",
            "toml (default, with comments), json, mat, npz, or py (a Python controller)",
            {"type": "string", "enum": list(ctl.FORMATS)},
        ),
    ),
    errors=(404, 422),
)
async def controller_template(request: Request) -> Response:
    """A controller file to edit: the plant's predefined controller, every field explained"""
    plant = plant_of(request)
    fmt = query(request, "format")
    fmt = "toml" if fmt is None else fmt
    # on a thread: the template's law is realised with python-control, and .mat written by
    # scipy.io (seconds of first imports that must not stall the event loop)
    data = await asyncio.to_thread(lambda: ctl.template(plant, fmt))
    return Response(
        data,
        media_type=MEDIA[fmt],
        headers={"content-disposition": f'attachment; filename="{plant.id}-controller.{fmt}"'},
    )


FORM = {
    "type": "object",
    "required": ["plant", "file"],
    "properties": {
        "plant": {"type": "string", "enum": list(PLANTS)},
        "file": {"type": "string", "format": "binary", "description": "the controller file"},
        "format": {
            "type": "string",
            "enum": list(ctl.FORMATS),
            "description": "default: from the file's name",
        },
        "name": {"type": "string", "maxLength": 80},
    },
    "additionalProperties": False,
}


@endpoint(
    "POST",
    "/controllers",
    body=s.ControllerUpload,
    form=FORM,
    response=s.UploadedController,
    status=201,
    errors=(404, 413, 415, 422, 429, 503),
    links=(("get_controller", "controller_id"), ("delete_controller", "controller_id")),
)
async def upload_controller(request: Request) -> Response:
    """Upload a controller file: read, checked on the plant's model, kept with its report

    The file is at most 64 KiB (base64 for .mat and .npz). The answer has the law read
    from it and its report: closed-loop poles, margins, peak control voltage, problems
    (which keep it off the real rig) and warnings. A Python controller (``py``) is checked
    by trial runs on the model in its sandbox (a step and a square wave, about a second),
    and its report has its compute time per step. A file that cannot be read gets 422
    naming the line and column or the field, and nothing is stored. At most
    ``ELAB_MAX_CONTROLLERS_PER_IDENTITY`` (100) per identity.

    The file may also come as ``multipart/form-data`` (``curl -F plant=flexible_link -F
    file=@ctrl.mat``): fields ``plant``, ``file``, and optionally ``format`` (default: from
    the file's name) and ``name``."""
    # an upload: within ELAB_MAX_UPLOAD, not the 1 MiB of other bodies (90,000 characters
    # of content may take 12 bytes each as JSON escapes)
    if _media(request) == "multipart/form-data":
        req, data = await _form(request)
    else:
        req = await read_model(request, s.ControllerUpload, upload=True)
        data = _content(req)
    if req.plant not in PLANTS:
        raise InvalidInput("plant", req.plant, "one of " + ", ".join(PLANTS))
    plant = get_plant(req.plant)
    who = identity(request)
    limit = lab(request).settings.max_controllers_per_identity
    with lab(request).pending.hold("controllers", who.id) as others:
        have = await asyncio.to_thread(store(request).count_controllers, who.id)
        within_budget(have + others, limit, "controllers", "ELAB_MAX_CONTROLLERS_PER_IDENTITY")
        # in a worker process of the trial pool: a wall-clock limit kills a trial that
        # takes too long, and trials never hold the threads that answer other requests
        parsed, report = await lab(request).trials.run(
            _read_and_check, data, req.format, plant, lab(request).settings.engine.code
        )
        stored = StoredController(
            id="c-" + secrets.token_hex(6),
            owner=who.id,
            plant=plant.id,
            name=req.name or parsed.name or f"{plant.id} {req.format} controller",
            format=req.format,
            law=ctl.law_fields(parsed.law),
            report=_report_json(report),
            created_at=time.time(),
            source=data,
        )
        await asyncio.to_thread(store(request).add_controller, stored)
    return ok(controller_out(stored, who), status=201)


def _media(request: Request) -> str:
    return request.headers.get("content-type", "").split(";")[0].strip().lower()


async def _form(request: Request) -> tuple[s.ControllerUpload, bytes]:
    """A controller file sent as a form: read within ``ELAB_MAX_UPLOAD``, then parsed
    (one file, a few fields, none larger than a controller file may be)."""
    body = await read_body(request, upload=True)

    async def stream() -> AsyncGenerator[bytes, None]:
        yield body

    try:
        form = await MultiPartParser(
            request.headers, stream(), max_files=1, max_fields=3, max_part_size=8 * 1024
        ).parse()
    except (MultiPartException, ValueError, KeyError) as exc:
        raise InvalidInput(
            "body",
            f"an unreadable form ({exc})",
            "multipart/form-data with plant, file and optionally format and name",
        ) from None
    try:
        unknown = sorted(set(form.keys()) - {"plant", "file", "format", "name"})
        if unknown:
            raise InvalidInput(unknown[0], "given", "the fields plant, file, format, name")
        upload = form.get("file")
        if not isinstance(upload, UploadFile):
            raise InvalidInput(
                "file", None, "a file part named file (curl -F file=@my_controller.toml)"
            )
        fields = {k: form.get(k) for k in ("plant", "format", "name")}
        for k, v in fields.items():
            if v is not None and not isinstance(v, str):
                raise InvalidInput(k, "a file", "a text field")
        fmt = fields["format"] or ctl.format_of(upload.filename or "")
        data = await upload.read(ctl.file_format.MAX_BYTES + 1)
    finally:
        await form.close()
    if not data:
        raise InvalidInput("file", "an empty file", "a controller file")
    req = s.ControllerUpload.model_validate(
        {
            "plant": fields["plant"] or "",
            "format": fmt,
            "content": "-",  # the file is in data, read as bytes
            "name": fields["name"] or (upload.filename or "")[:80] or None,
        }
    )
    return req, data


def _content(req: s.ControllerUpload) -> bytes:
    if req.format in ("toml", "json", "py"):
        return req.content.encode("utf-8")
    try:
        return base64.b64decode(req.content, validate=True)
    except (binascii.Error, ValueError):
        raise InvalidInput(
            "content", req.content[:20], f"the .{req.format} file in base64"
        ) from None


def _read_and_check(
    data: bytes, fmt: str, plant: Any, settings: CodeSettings
) -> tuple[ctl.Controller, ctl.Report]:
    from elab.engines import coded  # in the trial worker (JOB_MODULES), not the web process

    parsed = ctl.read_controller(data, fmt, plant)
    return parsed, coded.report(plant, parsed.law, settings)


@endpoint(
    "GET", "/controllers", response=s.UploadedControllerList, params=(PLANT_FILTER,), errors=(422,)
)
async def list_controllers(request: Request) -> Response:
    """The caller's uploaded controllers, newest first (an instructor's: everyone's)"""
    plant = plant_filter(request)
    who = identity(request)
    owner = None if who.instructor else who.id
    found = await asyncio.to_thread(store(request).list_controllers, owner, plant)
    return ok(s.UploadedControllerList(controllers=[controller_out(c, who) for c in found]))


@endpoint("GET", "/controllers/{controller_id}", response=s.UploadedController, errors=(404,))
async def get_controller(request: Request) -> Response:
    """An uploaded controller: its law and report"""
    who = identity(request)
    return ok(
        controller_out(await visible(request, request.path_params["controller_id"], who), who)
    )


@endpoint("DELETE", "/controllers/{controller_id}", status=204, errors=(404, 503))
async def delete_controller(request: Request) -> Response:
    """Delete an uploaded controller (runs made with it keep their record of it)"""
    c = await visible(request, request.path_params["controller_id"], identity(request))
    await asyncio.to_thread(store(request).delete_controller, c.id)
    return Response(status_code=204)


async def visible(conn: HTTPConnection, controller_id: str, who: Identity) -> StoredController:
    """The controller if ``who`` may use it (its owner, an instructor), else 404: someone
    else's controller does not exist for them."""
    c = await asyncio.to_thread(store(conn).get_controller, controller_id)
    if not may_control(who, c.owner):
        raise NotFound("controller", controller_id)
    return c


async def law_of(conn: HTTPConnection, controller_id: str, plant_id: str) -> ControlLaw:
    """The law of an uploaded controller for a run of ``plant_id``, as the caller."""
    c = await visible(conn, controller_id, identity(conn))
    if c.plant != plant_id:
        raise InvalidInput(
            "controller_id",
            controller_id,
            f"a controller for {plant_id} (this one is for {c.plant})",
        )
    return stored_law(c)


def stored_law(c: StoredController) -> ControlLaw:
    """The law of a stored controller (a Python one's is its source)."""
    if c.format == "py":
        return CodeController(c.source.decode("utf-8"), str(c.law.get("file", "controller.py")))
    return ctl.law_from_fields(c.law, get_plant(c.plant))


def _source(law: ControlLaw) -> str | None:
    """A Python controller's source (``None``: an empty one, or a declarative law)."""
    match law:
        case CodeController(source=source):
            return source or None
        case _:
            return None


def controller_out(c: StoredController, who: Identity) -> s.UploadedController:
    law = stored_law(c)
    return s.UploadedController(
        id=c.id,
        plant=c.plant,
        name=c.name,
        format=c.format,
        owner=display_name(c.owner),
        mine=bool(who.id) and c.owner == who.id,
        created_at=c.created_at,
        controller=None if is_code(law) else convert.law_model(law),
        # the list leaves sources out: GET /controllers/{id} has it
        code=_source(law),
        report=s.ControllerReportOut.model_validate(c.report),
        url=f"/api/v1/controllers/{c.id}",
    )


def _report_json(r: ctl.Report) -> dict[str, Any]:
    def finite(x: float | None) -> float | None:
        return x if x is not None and math.isfinite(x) else None

    return {
        "stable": r.stable,
        "domain": r.domain,
        "poles": [{"re": p.real, "im": p.imag} for p in r.poles],
        "gain_margin_db": finite(r.gain_margin_db),
        "phase_margin_deg": finite(r.phase_margin_deg),
        "peak_u": finite(r.peak_u),
        "u_max": r.u_max,
        "step_amplitude": r.step_amplitude,
        "rig_ready": r.rig_ready,
        "problems": list(r.problems),
        "warnings": list(r.warnings),
        "compute": r.compute,
        "trial": r.trial,
    }
