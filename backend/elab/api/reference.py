"""The OpenAPI 3.1 document, built from the endpoint registry and the pydantic
models, and a readable HTML reference page rendered from it (no external JS)."""

from __future__ import annotations

import html
import json
from typing import Any

from pydantic import TypeAdapter

from elab.api import schemas as s
from elab.api.http import ENDPOINTS, Endpoint

REF = "#/components/schemas/{model}"
STATUS_TEXT = {200: "OK", 201: "Created", 404: "Unknown id", 409: "Conflict with the run's state",
               413: "Body too large", 422: "Invalid input (every field error listed)",
               429: "Too many live runs"}
STREAM_TEXT = """The live stream of a run: websocket `GET /api/v1/runs/{run_id}/stream`,
subprotocol `elab.v1`, every message one msgpack map with a `type`. The server sends `hello`
(the run, its channels and `frame_samples` F), then `frame` messages (frame `seq` holds samples
[seq·F, (seq+1)·F); `columns` maps each channel to float32 little-endian bytes; t = k·Ts),
`status`, `params` (a live change and its sample index), `skipped` (frames a slow watcher
did not get) and `error`. The client may send `set_params`, `pause`, `resume`, `stop` and
`resume_from` {seq}: every sample from frame seq on, from the recording. Query `from_seq=N`
starts there. Close codes: 4404 unknown run, 4400 missing subprotocol."""


def _schema(tp: Any, defs: dict[str, Any]) -> dict[str, Any]:
    schema = TypeAdapter(tp).json_schema(ref_template=REF, mode="serialization")
    defs.update(schema.pop("$defs", {}))
    return schema


def _operation(e: Endpoint, defs: dict[str, Any]) -> dict[str, Any]:
    op: dict[str, Any] = {"summary": e.summary, "operationId": e.handler.__name__,
                          "tags": [e.path.split("/")[1]]}
    if e.handler.__doc__:
        op["description"] = " ".join(e.handler.__doc__.split())
    if e.params:
        op["parameters"] = [{"name": p.name, "in": p.where, "required": p.required or
                             p.where == "path", "description": p.description, "schema": p.schema}
                            for p in e.params]
    if e.body is not None:
        op["requestBody"] = {"required": True, "content": {
            "application/json": {"schema": _schema(e.body, defs)}}}
    if e.response == "file":
        content = {m: {"schema": {"type": "string", "format": "binary"}}
                   for m in ("text/csv", "application/json", "application/x-matlab-data")}
    else:
        content = {"application/json": {"schema": _schema(e.response, defs)}}
    op["responses"] = {str(e.status): {"description": STATUS_TEXT.get(e.status, "OK"),
                                       "content": content}}
    for code in e.errors:
        op["responses"][str(code)] = {"description": STATUS_TEXT[code], "content": {
            "application/json": {"schema": _schema(s.ErrorBody, defs)}}}
    return op


def openapi_document() -> dict[str, Any]:
    defs: dict[str, Any] = {}
    paths: dict[str, Any] = {}
    for e in ENDPOINTS:
        paths.setdefault("/api/v1" + e.path, {})[e.method.lower()] = _operation(e, defs)
    for tp in (s.ServerMessage, s.ClientMessage):
        _schema(tp, defs)
    return {"openapi": "3.1.0",
            "info": {"title": "E-Lab API", "version": s.PROTOCOL, "description": STREAM_TEXT},
            "paths": paths, "components": {"schemas": dict(sorted(defs.items()))}}


def wire_schema() -> dict[str, Any]:
    """Every wire model as one JSON Schema (``shared/elab.v1.schema.json``)."""
    defs: dict[str, Any] = {}
    roots: dict[str, Any] = {"RunCreate": s.RunCreate, "RunInfo": s.RunInfo, "RunList": s.RunList,
             "ParamsUpdate": s.ParamsUpdate, "ParamsApplied": s.ParamsApplied,
             "PlantSummary": s.PlantSummary, "PlantDetail": s.PlantDetail,
             "AnalysisInfo": s.AnalysisInfo, "BodeList": s.BodeList, "StepRequest": s.StepRequest,
             "StepOut": s.StepOut, "LQRRequest": s.LQRRequest, "PlaceRequest": s.PlaceRequest,
             "DesignOut": s.DesignOut, "ErrorBody": s.ErrorBody,
             "ServerMessage": s.ServerMessage, "ClientMessage": s.ClientMessage}
    ref = "#/$defs/{model}"
    for name, tp in roots.items():
        schema = TypeAdapter(tp).json_schema(ref_template=ref, mode="serialization")
        defs.update(schema.pop("$defs", {}))
        if name not in defs:
            defs[name] = schema
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "$id": s.PROTOCOL,
            "title": "E-Lab wire protocol elab.v1", "$defs": dict(sorted(defs.items()))}


def reference_page(doc: dict[str, Any]) -> str:
    """The API reference as one self-contained HTML page."""
    esc = html.escape
    out = [f"<!doctype html><html lang=en><meta charset=utf-8><title>{esc(doc['info']['title'])}"
           "</title><style>body{font:15px/1.5 system-ui,sans-serif;max-width:960px;margin:2rem "
           "auto;padding:0 1rem;color:#222}code,pre{font:13px ui-monospace,monospace;background:"
           "#f4f4f6;border-radius:4px}pre{padding:.6rem;overflow:auto}h3{margin-top:2rem}"
           ".m{display:inline-block;min-width:4.2em;font-weight:600}"
           "table{border-collapse:collapse}td,th{padding:.2rem .6rem;border-bottom:1px solid #ddd;"
           "text-align:left;vertical-align:top}</style>",
           f"<h1>{esc(doc['info']['title'])} <small>{esc(doc['info']['version'])}</small></h1>",
           "<p>Machine-readable: <a href=/api/v1/openapi.json>/api/v1/openapi.json</a>. "
           "Errors are <code>{\"error\": {\"code\", \"message\", \"field\", \"errors\"}}</code>."
           "</p><h2>Live stream</h2><p>" + esc(doc["info"]["description"])
           + "</p><h2>Endpoints</h2>"]
    for path, ops in doc["paths"].items():
        for method, op in ops.items():
            out.append(_op_html(method, path, op))
    out.append("<h2>Schemas</h2>")
    for name, schema in doc["components"]["schemas"].items():
        out.append(f"<h3 id={esc(name)}>{esc(name)}</h3><pre>"
                   f"{esc(json.dumps(schema, indent=1))}</pre>")
    return "".join(out)


def _op_html(method: str, path: str, op: dict[str, Any]) -> str:
    esc = html.escape
    parts = [f"<h3><span class=m>{method.upper()}</span> <code>{esc(path)}</code></h3>"
             f"<p>{esc(op['summary'])}. {esc(op.get('description', ''))}</p>"]
    if op.get("parameters"):
        rows = "".join(f"<tr><td><code>{esc(p['name'])}</code></td><td>{p['in']}</td>"
                       f"<td>{esc(p['description'])}</td></tr>" for p in op["parameters"])
        parts.append(f"<table><tr><th>parameter</th><th>in</th><th>meaning</th></tr>{rows}"
                     "</table>")
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
