"""Messages between the run manager and an engine process: plain data, no pickles.

A message is a JSON header and an optional binary payload (sample blocks as
raw little-endian float64), framed as ``[u32 header length][u32 payload
length][header][payload]``. Nothing here executes what it decodes: run specs
are rebuilt from a fixed list of laws and signals, so the same messages can
later go through a broker between machines.

Both directions are typed: a :data:`Command` (web process → engine) and an
:data:`Event` (engine → web process) are frozen dataclasses, encoded by
:func:`command_out` / :func:`event_out` and decoded by :func:`command_in` /
:func:`event_in`; the engine process and :class:`~elab.engines.process.ProcessEngine`
dispatch on them with ``match`` and ``assert_never``, so a new message fails mypy
wherever it must be handled (``scripts/check_dispatch.py``).
"""

from __future__ import annotations

import dataclasses
import json
import struct
from dataclasses import dataclass
from typing import Any, assert_never

import numpy as np

from elab import laws
from elab.engines.base import Action, Block, Changed, Ended, Health, RunOrder, StoreHealth
from elab.errors import Conflict, ElabError, InvalidInput, NotFound, TooMany, Unavailable
from elab.laws import ControlLaw
from elab.lifecycle import RunState
from elab.plants import get_plant
from elab.sim import signals
from elab.sim.signals import Signal
from elab.sim.spec import RunSpec
from elab.store.base import ParamChange, RunRecord

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


# -- commands: web process → engine ----------------------------------------------------
@dataclass(frozen=True)
class Add:
    """Take a new run (the answer: its record)."""

    id: int
    order: RunOrder


@dataclass(frozen=True)
class Control:
    """Pause, resume or stop a run (the answer: the sample it happened at)."""

    id: int
    run: str
    action: Action
    reason: str | None


@dataclass(frozen=True)
class Replace:
    """Change a live run's law, reference or parameters (the answer: the sample)."""

    id: int
    run: str
    law: ControlLaw | None
    reference: Signal | None
    params: dict[str, Any]


@dataclass(frozen=True)
class Close:
    """End the engine: its runs end with ``reason``."""

    reason: str


Command = Add | Control | Replace | Close


def command_out(cmd: Command) -> bytes:
    """One framed command."""
    match cmd:
        case Add():
            return frame({"op": "add", "id": cmd.id, "order": order_out(cmd.order)})
        case Control():
            h = {"op": "control", "id": cmd.id, "run": cmd.run, "action": cmd.action}
            return frame({**h, "reason": cmd.reason})
        case Replace():
            h = {"op": "replace", "id": cmd.id, "run": cmd.run, "params": cmd.params}
            return frame({**h, "law": plain(cmd.law), "reference": plain(cmd.reference)})
        case Close():
            return frame({"op": "close", "reason": cmd.reason})
        case _:
            assert_never(cmd)


def command_in(h: dict[str, Any]) -> Command:
    """The command a header holds; ``ValueError`` for one this engine does not know."""
    match h.get("op"):
        case "add":
            return Add(h["id"], order_in(h["order"]))
        case "control":
            return Control(h["id"], h["run"], h["action"], h["reason"])
        case "replace":
            law, reference = typed(h["law"]), typed(h["reference"])
            return Replace(h["id"], h["run"], law, reference, h["params"])
        case "close":
            return Close(str(h.get("reason") or "server shut down"))
        case op:
            raise ValueError(f"unknown engine command {op!r}")


# -- events: engine → web process -------------------------------------------------------
@dataclass(frozen=True)
class Ready:
    """The engine is up; ``interrupted``: runs its earlier end interrupted."""

    engine: str
    pid: int
    interrupted: list[str]


@dataclass(frozen=True)
class Reply:
    """The answer to command ``id``: ``ok``, or ``error``."""

    id: int
    ok: Any = None
    error: ElabError | None = None


@dataclass(frozen=True)
class Blocks:
    blocks: list[Block]


@dataclass(frozen=True)
class StateChanged:
    change: Changed


@dataclass(frozen=True)
class Started:
    record: RunRecord


@dataclass(frozen=True)
class Params:
    run: str
    change: ParamChange


@dataclass(frozen=True)
class Committed:
    counts: dict[str, int]


@dataclass(frozen=True)
class Stored:
    run: str


@dataclass(frozen=True)
class RunEnded:
    run: str
    ended: Ended


@dataclass(frozen=True)
class Beat:
    """The heartbeat, with the engine's health."""

    health: Health


Event = (
    Ready | Reply | Blocks | StateChanged | Started | Params | Committed | Stored | RunEnded | Beat
)


def event_out(ev: Event) -> bytes:
    """One framed event."""
    match ev:
        case Ready():
            return frame({"ev": "ready", **dataclasses.asdict(ev)})
        case Reply(error=None):
            return frame({"ev": "reply", "id": ev.id, "ok": ev.ok})
        case Reply():
            assert ev.error is not None
            return frame({"ev": "reply", "id": ev.id, "error": error_out(ev.error)})
        case Blocks():
            return blocks_out(ev.blocks)
        case StateChanged():
            return frame(changed_out(ev.change))
        case Started():
            return frame({"ev": "started", "record": record_out(ev.record)})
        case Params():
            c = ev.change
            return frame({"ev": "params", "run": ev.run, "k": c.k, "params": c.params, "at": c.at})
        case Committed():
            return frame({"ev": "committed", "counts": ev.counts})
        case Stored():
            return frame({"ev": "stored", "run": ev.run})
        case RunEnded():
            return frame({"ev": "ended", "run": ev.run, **ended_out(ev.ended)})
        case Beat():
            return frame(health_out(ev.health))
        case _:
            assert_never(ev)


def event_in(h: dict[str, Any], payload: bytes) -> Event:
    """The event a header (and payload) holds; ``ValueError`` for one not known here."""
    match h.get("ev"):
        case "ready":
            return Ready(h["engine"], h["pid"], h["interrupted"])
        case "reply" if "error" in h:
            return Reply(h["id"], error=error_in(h["error"]))
        case "reply":
            return Reply(h["id"], ok=h["ok"])
        case "blocks":
            return Blocks(blocks_in(h, payload))
        case "changed":
            return StateChanged(changed_in(h))
        case "started":
            return Started(record_in(h["record"]))
        case "params":
            return Params(h["run"], ParamChange(h["k"], h["params"], h["at"]))
        case "committed":
            return Committed(h["counts"])
        case "stored":
            return Stored(h["run"])
        case "ended":
            return RunEnded(h["run"], ended_in(h))
        case "health":
            return Beat(health_in(h))
        case ev:
            raise ValueError(f"unknown engine event {ev!r}")


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
