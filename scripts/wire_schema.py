"""Write the wire protocol's JSON Schema, ``shared/elab.v1.schema.json``.

Run ``make protocol``: this script, then ``frontend/scripts/gen-protocol.mjs``, which
turns the schema into ``frontend/src/protocol.gen.ts``. ``tests/unit/test_wire_schema.py``
fails when either committed file differs from what the pydantic models give.
"""

from __future__ import annotations

import json
from pathlib import Path

from elab.api.reference import wire_schema

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = ROOT / "shared" / "elab.v1.schema.json"


def render() -> str:
    return json.dumps(wire_schema(), indent=2, ensure_ascii=False) + "\n"


if __name__ == "__main__":
    SCHEMA.write_text(render(), encoding="utf-8")
    print(f"wrote {SCHEMA.relative_to(ROOT)}")
