"""The OpenAPI 3.1 document, built from the endpoint registry and the pydantic
models, and a readable HTML reference page rendered from it (no external JS)."""

from __future__ import annotations

import html
import json
from typing import Any, Literal, get_args

from pydantic import BaseModel, RootModel
from pydantic.json_schema import models_json_schema

from elab.api import schemas as s
from elab.api.http import ENDPOINTS, Endpoint
from elab.api.paths import path_params

REF = "#/components/schemas/{model}"
STATUS_TEXT = {
    200: "OK",
    201: "Created",
    204: "Done (no content)",
    401: "An unknown or revoked API token, or a wrong password",
    403: "Not yours: only the owner or an instructor may (or a request from another site)",
    404: "Unknown id (or a private run of someone else)",
    408: "The body stopped coming for ELAB_BODY_TIMEOUT s",
    415: "The body is not application/json",
    409: "Conflict with the run's state",
    413: "Body too large",
    422: "Invalid input (every field error listed)",
    429: "A limit on concurrent work (Retry-After says when to retry)",
    503: "A part of the server is down or failing (the engine, the store)",
}
SECURITY = {
    "bearer": {
        "type": "http",
        "scheme": "bearer",
        "description": "an API token from POST /api/v1/tokens: acts as the identity that made it",
    },
    "browser": {
        "type": "apiKey",
        "in": "cookie",
        "name": "elab_id",
        "description": "a browser's anonymous identity, set with the first response",
    },
    "instructor": {
        "type": "apiKey",
        "in": "cookie",
        "name": "elab_session",
        "description": "an instructor signed in with POST /api/v1/session",
    },
}
STREAM_TEXT = """The live stream of a run: websocket `GET /api/v1/runs/{run_id}/stream`,
subprotocol `elab.v1`, every message one msgpack map with a `type`. The server sends `hello`
(the run, its channels and `frame_samples` F), then `frame` messages (frame `seq` holds samples
[seq·F, (seq+1)·F); `columns` maps each channel to float32 little-endian bytes; t = k·Ts),
`status`, `params` (a live change and its sample index), `skipped` (frames a slow watcher
did not get) and `error`. The client may send `set_params`, `pause`, `resume`, `stop` and
`resume_from` {seq}: every sample from frame seq on, from the recording. Query `from_seq=N`
starts there. Close codes: 4404 unknown run, 4400 missing subprotocol."""


Mode = Literal["validation", "serialization"]


def _model(tp: Any) -> type[BaseModel]:
    """``tp`` itself if it is a model, else a root model around it (a union, a list)."""
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return tp
    if id(tp) not in _ROOTS:
        name = _UNION_NAMES.get(id(tp)) or f"{get_args(tp)[0].__name__}List"
        _ROOTS[id(tp)] = type(name, (RootModel[tp],), {"__module__": s.__name__})
    return _ROOTS[id(tp)]


_UNION_NAMES = {
    id(s.ServerMessage): "ServerMessage",
    id(s.ClientMessage): "ClientMessage",
    id(s.Controller): "Controller",
    id(s.Signal): "Signal",
}
_ROOTS: dict[int, type[BaseModel]] = {}


def _schemas(
    roots: list[tuple[Any, Mode]], template: str
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """JSON Schema refs for ``roots`` and their shared definitions.

    Requests are read in validation mode (fields with defaults optional), responses and
    server messages in serialization mode (every field present); a model used both ways
    gets two definitions, ``Name-Input`` and ``Name-Output``.
    """
    models = [(_model(tp), mode) for tp, mode in roots]
    refs, top = models_json_schema(models, ref_template=template)
    return [refs[m] for m in models], top.get("$defs", {})


def openapi_document() -> dict[str, Any]:
    roots: list[tuple[Any, Mode]] = [
        (s.ErrorBody, "serialization"),
        (s.ServerMessage, "serialization"),
        (s.ClientMessage, "validation"),
        (s.RecordingOut, "serialization"),  # a download as JSON
    ]
    for e in ENDPOINTS:
        if e.body is not None:
            roots.append((e.body, "validation"))
        if e.response is not None and e.response != "file":
            roots.append((e.response, "serialization"))
        if e.stream is not None:
            roots.append((e.stream, "serialization"))
    refs, defs = _schemas(roots, REF)
    ref = dict(zip(((id(tp), mode) for tp, mode in roots), refs, strict=True))
    paths: dict[str, Any] = {}
    for e in ENDPOINTS:
        paths.setdefault("/api/v1" + e.path, {})[e.method.lower()] = _operation(e, ref)
    return {
        "openapi": "3.1.0",
        "info": {"title": "E-Lab API", "version": s.PROTOCOL, "description": STREAM_TEXT},
        "paths": paths,
        "components": {"schemas": dict(sorted(defs.items())), "securitySchemes": SECURITY},
        # every operation answers without credentials too (a new anonymous identity)
        "security": [{}, {"bearer": []}, {"browser": []}, {"instructor": []}],
    }


def _operation(e: Endpoint, ref: dict[tuple[int, Mode], dict[str, Any]]) -> dict[str, Any]:
    op: dict[str, Any] = {
        "summary": e.summary,
        "operationId": e.handler.__name__,
        "tags": [e.path.split("/")[1]],
    }
    if e.description:
        op["description"] = e.description
    params = path_params(e.path) + e.params
    if params:
        op["parameters"] = [
            {
                "name": p.name,
                "in": p.where,
                "required": p.required or p.where == "path",
                "description": p.description,
                "schema": p.schema,
            }
            for p in params
        ]
    if e.body is not None:
        op["requestBody"] = {
            "required": True,
            "content": {"application/json": {"schema": ref[id(e.body), "validation"]}},
        }
        if e.form is not None:
            op["requestBody"]["content"]["multipart/form-data"] = {"schema": e.form}
    if e.response is None:
        content = {}
    elif e.response == "file":
        media = e.files or ("text/csv", "application/x-matlab-data", "application/json")
        content = {
            m: {"schema": {"type": "string", "format": "binary"}}
            for m in media
            if m != "application/json"
        }
        if "application/json" in media:  # a recording, or a file's JSON document
            json_schema = (
                {"type": "object"} if e.files else ref[id(s.RecordingOut), "serialization"]
            )
            content["application/json"] = {"schema": json_schema}
    else:
        content = {"application/json": {"schema": ref[id(e.response), "serialization"]}}
    if e.stream is not None:  # with Accept: application/x-ndjson, one such object per line
        content["application/x-ndjson"] = {"schema": ref[id(e.stream), "serialization"]}
    op["responses"] = {
        str(e.status): {"description": STATUS_TEXT.get(e.status, "OK"), "content": content}
    }
    if e.status == 204:
        op["responses"]["204"] = {"description": STATUS_TEXT[204]}
    if e.links:
        op["responses"][str(e.status)]["links"] = {
            target: {"operationId": target, "parameters": {param: "$response.body#/id"}}
            for target, param in e.links
        }
    body_codes = (408,) if e.body is not None or e.form is not None else ()
    for code in sorted({*e.errors, *body_codes}):
        op["responses"][str(code)] = {
            "description": STATUS_TEXT[code],
            "content": {"application/json": {"schema": ref[id(s.ErrorBody), "serialization"]}},
        }
    return op


#: The wire schema's roots: what clients send (validation) and what they receive.
WIRE_ROOTS: list[tuple[Any, Mode]] = [
    (s.RunCreate, "validation"),
    (s.ParamsUpdate, "validation"),
    (s.StepRequest, "validation"),
    (s.LQRRequest, "validation"),
    (s.PlaceRequest, "validation"),
    (s.ClientMessage, "validation"),
    (s.RunInfo, "serialization"),
    (s.RunList, "serialization"),
    (s.ParamsApplied, "serialization"),
    (s.RunPrediction, "serialization"),
    (s.PlantSummary, "serialization"),
    (s.HelpIndex, "serialization"),
    (s.HelpPage, "serialization"),
    (s.PlantDetail, "serialization"),
    (s.AnalysisInfo, "serialization"),
    (s.BodeList, "serialization"),
    (s.StepOut, "serialization"),
    (s.DesignOut, "serialization"),
    (s.ModelCreate, "validation"),
    (s.IdentifiedModel, "serialization"),
    (s.IdentifiedModelList, "serialization"),
    (s.ModelDesignRequest, "validation"),
    (s.ModelDesignOut, "serialization"),
    (s.LoopRequest, "validation"),
    (s.LoopOut, "serialization"),
    (s.ControllerFileRequest, "validation"),
    (s.ErrorBody, "serialization"),
    (s.ServerMessage, "serialization"),
    (s.IdentRequest, "validation"),
    (s.IdentOut, "serialization"),
    (s.IdentLine, "serialization"),
    (s.StreamClose, "serialization"),
    (s.Me, "serialization"),
    (s.SignIn, "validation"),
    (s.TokenCreate, "validation"),
    (s.TokenInfo, "serialization"),
    (s.TokenCreated, "serialization"),
    (s.DemoPin, "validation"),
    (s.DemoInfo, "serialization"),
    (s.ControllerUpload, "validation"),
    (s.UploadedController, "serialization"),
    (s.UploadedControllerList, "serialization"),
    (s.RigQueueInfo, "serialization"),
    (s.RigExtend, "validation"),
    # the unions by name, as clients build them and as the server describes them
    (s.Controller, "validation"),
    (s.Controller, "serialization"),
    (s.Signal, "validation"),
    (s.Signal, "serialization"),
]


def wire_schema() -> dict[str, Any]:
    """Every wire model as one JSON Schema (``shared/elab.v1.schema.json``)."""
    _, defs = _schemas(WIRE_ROOTS, "#/$defs/{model}")
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": s.PROTOCOL,
        "title": "E-Lab wire protocol elab.v1",
        "$defs": dict(sorted(defs.items())),
    }


def reference_page(doc: dict[str, Any]) -> str:
    """The API reference as one self-contained HTML page."""
    esc = html.escape
    out = [
        f"<!doctype html><html lang=en><meta charset=utf-8><title>{esc(doc['info']['title'])}"
        "</title><style>body{font:15px/1.5 system-ui,sans-serif;max-width:960px;margin:2rem "
        "auto;padding:0 1rem;color:#222}code,pre{font:13px ui-monospace,monospace;background:"
        "#f4f4f6;border-radius:4px}pre{padding:.6rem;overflow:auto}h3{margin-top:2rem}"
        ".m{display:inline-block;min-width:4.2em;font-weight:600}"
        "table{border-collapse:collapse}td,th{padding:.2rem .6rem;border-bottom:1px solid #ddd;"
        "text-align:left;vertical-align:top}</style>",
        f"<h1>{esc(doc['info']['title'])} <small>{esc(doc['info']['version'])}</small></h1>",
        "<p>Machine-readable: <a href=/api/v1/openapi.json>/api/v1/openapi.json</a>. "
        'Errors are <code>{"error": {"code", "message", "field", "errors"}}</code>.'
        "</p><h2>Live stream</h2><p>" + esc(doc["info"]["description"]) + "</p><h2>Endpoints</h2>",
    ]
    for path, ops in doc["paths"].items():
        for method, op in ops.items():
            out.append(_op_html(method, path, op))
    out.append("<h2>Schemas</h2>")
    for name, schema in doc["components"]["schemas"].items():
        out.append(
            f"<h3 id={esc(name)}>{esc(name)}</h3><pre>{esc(json.dumps(schema, indent=1))}</pre>"
        )
    return "".join(out)


def _op_html(method: str, path: str, op: dict[str, Any]) -> str:
    esc = html.escape
    parts = [
        f"<h3><span class=m>{method.upper()}</span> <code>{esc(path)}</code></h3>"
        f"<p>{esc(op['summary'])}. {esc(op.get('description', ''))}</p>"
    ]
    if op.get("parameters"):
        rows = "".join(
            f"<tr><td><code>{esc(p['name'])}</code></td><td>{p['in']}</td>"
            f"<td>{esc(p['description'])}</td></tr>"
            for p in op["parameters"]
        )
        parts.append(f"<table><tr><th>parameter</th><th>in</th><th>meaning</th></tr>{rows}</table>")
    if "requestBody" in op:
        parts.append("<p>Body: " + _ref_links(op["requestBody"]) + "</p>")
    codes = ", ".join(f"{c} {esc(r['description'])}" for c, r in op["responses"].items())
    parts.append(f"<p>Responses: {codes}. " + _ref_links(op["responses"]) + "</p>")
    return "".join(parts)


def _ref_links(obj: Any) -> str:
    refs = sorted(set(_refs(obj)))
    return " ".join(f"<a href=#{html.escape(r)}>{html.escape(r)}</a>" for r in refs)


def _refs(obj: Any) -> list[str]:
    if isinstance(obj, dict):
        found = [obj["$ref"].rsplit("/", 1)[1]] if "$ref" in obj else []
        return found + [r for v in obj.values() for r in _refs(v)]
    if isinstance(obj, list):
        return [r for v in obj for r in _refs(v)]
    return []
