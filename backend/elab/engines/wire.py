"""Messages between the run manager and an engine process: plain data, no pickles.

A message is a JSON header and an optional binary payload (sample blocks as
raw little-endian float64), framed as ``[u32 header length][u32 payload
length][header][payload]``. Nothing here executes what it decodes: run specs
are rebuilt from a fixed list of laws and signals, so the same messages can
later go through a broker between machines.
"""

from __future__ import annotations

import dataclasses
import json
import struct
from typing import Any

import numpy as np

from elab import laws
from elab.engines.base import Block, Changed, Ended, Health, RunOrder, StoreHealth
from elab.errors import Conflict, ElabError, InvalidInput, NotFound, TooMany, Unavailable
from elab.lifecycle import RunState
from elab.plants import get_plant
from elab.sim import signals
from elab.sim.spec import RunSpec
from elab.store.base import RunRecord

_FRAME = struct.Struct("<II")
HEADER_BYTES = _FRAME.size
MAX_HEADER = 64 << 20  # a header longer than this is a broken stream, not a message

#: the types a run spec may contain, by name
_TYPES: dict[str, type] = {
    cls.__name__: cls
    for cls in (
        laws.StateFeedback,
        laws.PID,
        laws.LTIController,
        laws.OpenLoop,
        laws.CodeController,
        signals.Step,
        signals.Square,
        signals.Sine,
        signals.Chirp,
        signals.PRBS,
        signals.Samples,
    )
}


def frame(header: dict[str, Any], payload: bytes = b"") -> bytes:
    """One framed message."""
    head = json.dumps(header, separators=(",", ":")).encode()
    return _FRAME.pack(len(head), len(payload)) + head + payload


def lengths(prefix: bytes) -> tuple[int, int]:
    """Header and payload lengths from a message's first :data:`HEADER_BYTES` bytes."""
    head, payload = _FRAME.unpack(prefix)
    if head > MAX_HEADER:
        raise ValueError(f"message header of {head} bytes: the stream is broken")
    return head, payload


# -- run specs ------------------------------------------------------------------------
def spec_out(spec: RunSpec) -> dict[str, Any]:
    return {
        f.name: spec.plant.id if f.name == "plant" else plain(getattr(spec, f.name))
        for f in dataclasses.fields(spec)
    }


def spec_in(data: dict[str, Any]) -> RunSpec:
    fields = {k: typed(v) for k, v in data.items()}
    fields["plant"] = get_plant(data["plant"])
    return RunSpec(**fields)


def plain(value: Any) -> Any:
    """A law, signal or any value of a spec as JSON-able data."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        if type(value).__name__ not in _TYPES:
            raise TypeError(f"{type(value).__name__} cannot go to an engine")
        return {
            "type": type(value).__name__,
            **{f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)},
        }
    if isinstance(value, tuple | list):
        return [plain(v) for v in value]
    if isinstance(value, complex):  # an observer's poles
        return {"type": "complex", "re": value.real, "im": value.imag}
    return value


def typed(value: Any) -> Any:
    """The inverse of :func:`plain`."""
    if isinstance(value, dict) and value.get("type") == "complex":
        return complex(value["re"], value["im"])
    if isinstance(value, dict) and "type" in value:
        cls = _TYPES[value["type"]]
        return cls(**{k: typed(v) for k, v in value.items() if k != "type"})
    if isinstance(value, list):
        return tuple(typed(v) for v in value)
    return value


def order_out(order: RunOrder) -> dict[str, Any]:
    return {
        "id": order.id,
        "spec": spec_out(order.spec),
        "pace": order.pace,
        "mode": order.mode,
        "experiment": order.experiment,
        "request": order.request,
        "owner": order.owner,
        "private": order.private,
    }


def order_in(data: dict[str, Any]) -> RunOrder:
    return RunOrder(
        id=data["id"],
        spec=spec_in(data["spec"]),
        pace=data["pace"],
        mode=data["mode"],
        experiment=data["experiment"],
        request=data["request"],
        owner=data["owner"],
        private=data["private"],
    )


def record_out(record: RunRecord) -> dict[str, Any]:
    return dataclasses.asdict(record)


def record_in(data: dict[str, Any]) -> RunRecord:
    return RunRecord(**{**data, "channels": tuple(tuple(c) for c in data["channels"])})


# -- events -------------------------------------------------------------------------
def blocks_out(blocks: list[Block]) -> bytes:
    groups = [[b.run_ids, b.k0, int(b.data.shape[1]), int(b.data.shape[2])] for b in blocks]
    payload = b"".join(np.ascontiguousarray(b.data, dtype="<f8").tobytes() for b in blocks)
    return frame({"ev": "blocks", "groups": groups}, payload)


def blocks_in(header: dict[str, Any], payload: bytes) -> list[Block]:
    out, at = [], 0
    for run_ids, k0, n, ncols in header["groups"]:
        size = len(run_ids) * n * ncols * 8
        data = np.frombuffer(payload, "<f8", count=size // 8, offset=at).reshape(
            len(run_ids), n, ncols
        )
        out.append(Block(run_ids, k0, data))
        at += size
    return out


def changed_out(change: Changed) -> dict[str, Any]:
    return {
        "ev": "changed",
        "run": change.run_id,
        "state": change.state.value,
        "k": change.k,
        "error": change.error,
        "compute": change.compute,
    }


def changed_in(h: dict[str, Any]) -> Changed:
    return Changed(h["run"], RunState(h["state"]), h["k"], h["error"], h.get("compute"))


def ended_out(ended: Ended) -> dict[str, Any]:
    return {"state": ended.state.value, "error": ended.error, "n": ended.n}


def ended_in(h: dict[str, Any]) -> Ended:
    return Ended(RunState(h["state"]), h["error"], h["n"])


def health_out(health: Health) -> dict[str, Any]:
    return {"ev": "health", **dataclasses.asdict(health)}


def health_in(h: dict[str, Any]) -> Health:
    fields = {k: v for k, v in h.items() if k != "ev"}
    return Health(**{**fields, "store": StoreHealth(**fields["store"])})


# -- errors ---------------------------------------------------------------------------
def error_out(exc: ElabError) -> dict[str, Any]:
    out: dict[str, Any] = {"type": type(exc).__name__, "message": str(exc)}
    if isinstance(exc, InvalidInput):
        out.update(field=exc.field, value=_json_safe(exc.value), allowed=exc.allowed)
    elif isinstance(exc, NotFound):
        out.update(kind=exc.kind, id=exc.id)
    elif isinstance(exc, Unavailable):
        out.update(retry_after=exc.retry_after)
    return out


def error_in(e: dict[str, Any]) -> ElabError:
    kind = e["type"]
    if "field" in e:
        return InvalidInput(e["field"], e["value"], e["allowed"])
    if kind == "NotFound":
        return NotFound(e["kind"], e["id"])
    if "retry_after" in e:
        return Unavailable(e["message"], retry_after=e["retry_after"])
    cls: type[ElabError] = {"Conflict": Conflict, "TooMany": TooMany}.get(kind, ElabError)
    return cls(e["message"])


def _json_safe(value: Any) -> Any:
    try:
        json.dumps(value)
        return value
    except (TypeError, ValueError):
        return repr(value)
