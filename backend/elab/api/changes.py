"""What a live change alters: the controller and reference a run uses now, and a new one's
difference from them, field by field (``POST /runs/{id}/params`` answers with it)."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Any

from elab.api import convert
from elab.api import schemas as s
from elab.plants import Plant
from elab.store.base import ParamChange, RunRecord

Scalar = float | int | str | bool | None
PARTS = ("controller", "signal")


def running(record: RunRecord, changes: Sequence[ParamChange], plant: Plant) -> dict[str, Any]:
    """The run's ``controller`` and ``signal`` now, as JSON like its request: the request's,
    then each recorded change in order (the predefined controller as its gains)."""
    now = {part: record.spec.get(part) for part in PARTS}
    for change in changes:
        now |= {part: change.params[part] for part in PARTS if part in change.params}
    return now | {"controller": resolved(now["controller"], plant)}


def resolved(controller: Any, plant: Plant) -> Any:
    """A controller's JSON, ``predefined`` replaced by the plant's law (what it runs)."""
    if isinstance(controller, dict) and controller.get("kind") == "predefined":
        return convert.law_model(plant.predefined).model_dump(mode="json")
    return controller


def diff(part: str, before: Any, after: Any) -> list[s.ParamDiff]:
    """The fields of ``after`` (JSON) that differ from ``before``, as ``part.field.index``
    paths; numbers equal to 12 significant digits count as equal (degrees typed in a form
    come back as radians a rounding away from the recorded value)."""
    old, new = dict(_flat(part, before)), dict(_flat(part, after))
    keys = list(new) + [k for k in old if k not in new]
    return [
        s.ParamDiff(field=k, before=old.get(k), after=new.get(k))
        for k in keys
        if not _same(old.get(k), new.get(k))
    ]


def _flat(path: str, value: Any) -> Iterator[tuple[str, Scalar]]:
    if isinstance(value, dict):
        for key, v in value.items():
            yield from _flat(f"{path}.{key}", v)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            yield from _flat(f"{path}.{i}", v)
    else:
        yield path, value


def _number(x: Scalar) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _same(a: Scalar, b: Scalar) -> bool:
    if _number(a) and _number(b):
        return math.isclose(float(a), float(b), rel_tol=1e-12)  # type: ignore[arg-type]
    return type(a) is type(b) and a == b
