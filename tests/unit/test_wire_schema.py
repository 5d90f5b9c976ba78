"""One wire schema: the committed JSON Schema and TypeScript types are what the
pydantic models give, and the OpenAPI document's references all resolve."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

import elab.api.app  # noqa: F401  (registers the endpoints)
from elab.api.reference import openapi_document, wire_schema

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
from wire_schema import SCHEMA, render  # noqa: E402


def _refs(node: Any) -> list[str]:
    if isinstance(node, dict):
        own = [node["$ref"]] if isinstance(node.get("$ref"), str) else []
        return own + [r for v in node.values() for r in _refs(v)]
    if isinstance(node, list):
        return [r for v in node for r in _refs(v)]
    return []


def test_committed_json_schema_is_current() -> None:
    assert SCHEMA.read_text(encoding="utf-8") == render(), "run `make protocol`"


def test_generated_typescript_is_current() -> None:
    node = shutil.which("node")
    assert node, "node is needed (make install)"
    assert (ROOT / "frontend" / "node_modules").is_dir(), "frontend dependencies: make install"
    done = subprocess.run(
        [node, "scripts/gen-protocol.mjs", "--check"],
        cwd=ROOT / "frontend",
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr + done.stdout


@pytest.mark.parametrize(
    "doc, prefix", [(wire_schema(), "#/$defs/"), (openapi_document(), "#/components/schemas/")]
)
def test_every_reference_resolves(doc: dict[str, Any], prefix: str) -> None:
    defs = doc.get("$defs") or doc["components"]["schemas"]
    refs = set(_refs(doc))
    assert refs, "no references at all"
    assert {r.removeprefix(prefix) for r in refs} <= set(defs)


def test_requests_keep_defaults_optional_and_responses_list_every_field() -> None:
    defs = wire_schema()["$defs"]
    assert defs["RunCreate"]["required"] == ["plant"]
    # a union's tag is required in requests too: the server cannot tell the kind without it
    assert defs["PIDController-Input"]["required"] == ["kind", "Kp"]
    assert set(defs["PIDController-Output"]["required"]) == {
        *("kind", "Kp", "Ki", "Kd", "N", "Tt", "b", "c")
    }
    assert "type" in defs["Frame"]["required"]
    assert defs["Frame"]["properties"]["columns"]["additionalProperties"]["format"] == "binary"


def test_openapi_bodies_are_read_as_requests() -> None:
    doc = openapi_document()
    body = doc["paths"]["/api/v1/runs"]["post"]["requestBody"]["content"]["application/json"]
    name = body["schema"]["$ref"].rsplit("/", 1)[1]
    assert doc["components"]["schemas"][name]["required"] == ["plant"]
    json.dumps(doc)  # serialisable as served
