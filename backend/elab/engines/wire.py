"""Messages between the run manager and an engine process: plain data, no pickles.

A message is a JSON header and an optional binary payload (sample blocks as
raw little-endian float64), framed as ``[u32 header length][u32 payload
length][header][payload]``. Nothing here executes what it decodes: run specs
are rebuilt from a fixed list of laws and signals, so the same messages can
later go through a broker between machines.

Both directions are typed: a :data:`Command` (web process → engine) and an
:data:`Event` (engine → web process) are frozen dataclasses, encoded by
:func:`command_out` / :func:`event_out` and decoded from a frame's bytes by
:func:`decode_command` / :func:`decode_event` (the JSON in between never leaves this
module); the engine process and :class:`~elab.engines.process.ProcessEngine` dispatch on
them with ``match`` and ``assert_never``, so a new message fails mypy wherever it must be
handled (``scripts/check_dispatch.py``). The engine's first message, :class:`Ready`, says
which :data:`PROTOCOL` it speaks; a web process refuses an engine that speaks another.
"""

from __future__ import annotations

import dataclasses
import json
import struct
from dataclasses import dataclass
from typing import Any, assert_never

import numpy as np

from elab import laws
from elab.engines.base import (
    Action,
    Block,
    Changed,
    Ended,
    EngineEvents,
    Health,
    NewParams,
    RigLink,
    RunOrder,
    StoreHealth,
)
from elab.errors import Conflict, ElabError, InvalidInput, NotFound, TooMany, Unavailable
from elab.lifecycle import RunState
from elab.plants import get_plant
from elab.sim import signals
from elab.sim.spec import RunSpec
from elab.store.base import ParamChange, RunRecord

#: The version of these messages; bumped with any change to a message's fields.
PROTOCOL = 3

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
    """Change a live run's law and/or reference (the answer: the sample)."""

    id: int
    run: str
    new: NewParams


@dataclass(frozen=True)
class Follow:
    """Say each live run again (``Started`` with its record and its order as it steps
    now, then its state if paused) for a web process that started after them (the
    answer: how many)."""

    id: int


@dataclass(frozen=True)
class Close:
    """End the engine: its runs end with ``reason``."""

    reason: str


Command = Add | Control | Replace | Follow | Close


def command_out(cmd: Command) -> bytes:
    """One framed command."""
    match cmd:
        case Add():
            return _frame({"op": "add", "id": cmd.id, "order": _order_out(cmd.order)})
        case Control():
            h = {"op": "control", "id": cmd.id, "run": cmd.run, "action": cmd.action}
            return _frame({**h, "reason": cmd.reason})
        case Replace():
            h = {"op": "replace", "id": cmd.id, "run": cmd.run, "params": cmd.new.asked}
            return _frame({**h, "law": _plain(cmd.new.law), "reference": _plain(cmd.new.reference)})
        case Follow():
            return _frame({"op": "follow", "id": cmd.id})
        case Close():
            return _frame({"op": "close", "reason": cmd.reason})
        case _:
            assert_never(cmd)


class Unreadable(ValueError):
    """A frame that holds no message known here; ``command_id``: the id of the command it
    seems to be (to answer it with an error), or -1."""

    def __init__(self, message: str, command_id: int = -1) -> None:
        super().__init__(message)
        self.command_id = command_id


def decode_command(head: bytes) -> Command:
    """The command in a frame's header; :class:`Unreadable` for one not known here."""
    h = _object(head)
    try:
        return _command_in(h)
    except (ValueError, KeyError, TypeError) as exc:
        cid = h.get("id")
        raise Unreadable(f"a command not understood: {exc!r}", _int_or(cid)) from exc


def decode_event(head: bytes, payload: bytes) -> Event:
    """The event in a frame's header and payload; :class:`Unreadable` for one not known."""
    try:
        return _event_in(_object(head), payload)
    except (ValueError, KeyError, TypeError) as exc:
        raise Unreadable(f"an event not understood: {exc!r}") from exc


def _object(head: bytes) -> dict[str, Any]:
    try:
        h = json.loads(head)
    except ValueError as exc:
        raise Unreadable(f"a header that is not JSON: {exc}") from exc
    if not isinstance(h, dict):
        raise Unreadable(f"a header that is not an object: {type(h).__name__}")
    return h


def _int_or(value: object, default: int = -1) -> int:
    return value if isinstance(value, int) else default


def _command_in(h: dict[str, Any]) -> Command:
    match h.get("op"):
        case "add":
            return Add(h["id"], _order_in(h["order"]))
        case "control":
            return Control(h["id"], h["run"], h["action"], h["reason"])
        case "replace":
            new = NewParams(_typed(h["law"]), _typed(h["reference"]), h["params"])
            return Replace(h["id"], h["run"], new)
        case "follow":
            return Follow(h["id"])
        case "close":
            return Close(str(h.get("reason") or "server shut down"))
        case op:
            raise ValueError(f"unknown engine command {op!r}")


# -- events: engine → web process -------------------------------------------------------
@dataclass(frozen=True)
class Ready:
    """The engine is up; ``interrupted``: runs its earlier end interrupted; ``protocol``:
    the :data:`PROTOCOL` it speaks; ``kind``: what it steps (``"simulation"``, ``"rig"``)."""

    engine: str
    pid: int
    interrupted: list[str]
    protocol: int = PROTOCOL
    kind: str = "simulation"


@dataclass(frozen=True)
class Reply:
    """The answer to command ``id``: ``ok`` (an added run's record, or the sample index a
    command took effect at), or ``error``."""

    id: int
    ok: RunRecord | int | None = None
    error: ElabError | None = None


@dataclass(frozen=True)
class Blocks:
    blocks: list[Block]


@dataclass(frozen=True)
class StateChanged:
    change: Changed


@dataclass(frozen=True)
class Started:
    """A run started; ``order``: what it was started with, for a web process that did not
    send it (engines on a broker are heard by every web process)."""

    record: RunRecord
    order: RunOrder | None = None


@dataclass(frozen=True)
class Params:
    """A run's parameters changed; ``new``: the change typed, for every web process's
    view of the run's law and reference."""

    run: str
    change: ParamChange
    new: NewParams | None = None


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
            return _frame({"ev": "ready", **dataclasses.asdict(ev)})
        case Reply(error=None, ok=RunRecord() as record):
            return _frame({"ev": "reply", "id": ev.id, "record": dataclasses.asdict(record)})
        case Reply(error=None):
            return _frame({"ev": "reply", "id": ev.id, "k": ev.ok})
        case Reply():
            assert ev.error is not None
            return _frame({"ev": "reply", "id": ev.id, "error": _error_out(ev.error)})
        case Blocks():
            return _blocks_out(ev.blocks)
        case StateChanged():
            return _frame(_changed_out(ev.change))
        case Started():
            order = None if ev.order is None else _order_out(ev.order)
            fields = dataclasses.asdict(ev.record)
            return _frame({"ev": "started", "record": fields, "order": order})
        case Params():
            c = ev.change
            h = {"ev": "params", "run": ev.run, "k": c.k, "params": c.params, "at": c.at}
            if ev.new is not None:
                h |= {"law": _plain(ev.new.law), "reference": _plain(ev.new.reference)}
            return _frame(h)
        case Committed():
            return _frame({"ev": "committed", "counts": ev.counts})
        case Stored():
            return _frame({"ev": "stored", "run": ev.run})
        case RunEnded():
            e = ev.ended
            h = {"ev": "ended", "run": ev.run, "state": e.state.value}
            return _frame({**h, "error": e.error, "n": e.n})
        case Beat():
            return _frame({"ev": "health", **dataclasses.asdict(ev.health)})
        case _:
            assert_never(ev)


def _event_in(h: dict[str, Any], payload: bytes) -> Event:
    match h.get("ev"):
        case "ready":
            return Ready(h["engine"], h["pid"], h["interrupted"], h["protocol"], h["kind"])
        case "reply" if "error" in h:
            return Reply(h["id"], error=_error_in(h["error"]))
        case "reply" if "record" in h:
            return Reply(h["id"], ok=_record_in(h["record"]))
        case "reply":
            return Reply(h["id"], ok=h["k"])
        case "blocks":
            return Blocks(_blocks_in(h, payload))
        case "changed":
            return StateChanged(_changed_in(h))
        case "started":
            order = h.get("order")
            return Started(_record_in(h["record"]), None if order is None else _order_in(order))
        case "params":
            new = None
            if "law" in h:
                new = NewParams(_typed(h["law"]), _typed(h["reference"]), h["params"])
            return Params(h["run"], ParamChange(h["k"], h["params"], h["at"]), new)
        case "committed":
            return Committed(h["counts"])
        case "stored":
            return Stored(h["run"])
        case "ended":
            return RunEnded(h["run"], Ended(RunState(h["state"]), h["error"], h["n"]))
        case "health":
            return Beat(_health_in(h))
        case ev:
            raise ValueError(f"unknown engine event {ev!r}")


def _frame(header: dict[str, Any], payload: bytes = b"") -> bytes:
    """One framed message."""
    head = json.dumps(header, separators=(",", ":")).encode()
    return _FRAME.pack(len(head), len(payload)) + head + payload


def unframe(frame: bytes) -> tuple[bytes, bytes]:
    """A whole framed message's header and payload (a message kept whole: on a broker)."""
    head, size = lengths(frame[:HEADER_BYTES])
    if len(frame) != HEADER_BYTES + head + size:
        raise Unreadable(f"a message of {len(frame)} bytes, framed as {head} + {size}")
    return frame[HEADER_BYTES : HEADER_BYTES + head], frame[HEADER_BYTES + head :]


def deliver(events: EngineEvents, engine: str, ev: Event) -> Reply | Beat | Ready | None:
    """Hand an engine's event to the run manager (``events``); the link's own messages
    (a reply, a heartbeat, the engine's ready) go back to the caller, whose they are."""
    match ev:
        case Blocks():
            events.blocks(engine, ev.blocks)
        case StateChanged():
            events.changed(engine, ev.change)
        case Started():
            events.started(engine, ev.record, ev.order)
        case Params():
            events.params(engine, ev.run, ev.change, ev.new)
        case Committed():
            events.committed(engine, ev.counts)
        case Stored():
            events.stored(engine, ev.run)
        case RunEnded():
            events.ended(engine, ev.run, ev.ended)
        case Reply() | Beat() | Ready():
            return ev
        case _:
            assert_never(ev)
    return None


def lengths(prefix: bytes) -> tuple[int, int]:
    """Header and payload lengths from a message's first :data:`HEADER_BYTES` bytes."""
    head, payload = _FRAME.unpack(prefix)
    if head > MAX_HEADER:
        raise ValueError(f"message header of {head} bytes: the stream is broken")
    return head, payload


# -- run specs ------------------------------------------------------------------------
def _spec_out(spec: RunSpec) -> dict[str, Any]:
    return {
        f.name: spec.plant.id if f.name == "plant" else _plain(getattr(spec, f.name))
        for f in dataclasses.fields(spec)
    }


def _spec_in(data: dict[str, Any]) -> RunSpec:
    fields = {k: _typed(v) for k, v in data.items()}
    fields["plant"] = get_plant(data["plant"])
    return RunSpec(**fields)


def _plain(value: object) -> object:
    """A law, signal or any value of a spec as JSON-able data."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        if type(value).__name__ not in _TYPES:
            raise TypeError(f"{type(value).__name__} cannot go to an engine")
        return {
            "type": type(value).__name__,
            **{f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)},
        }
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, complex):  # an observer's poles
        return {"type": "complex", "re": value.real, "im": value.imag}
    return value


def _typed(value: Any) -> Any:
    """The inverse of :func:`_plain`."""
    if isinstance(value, dict) and value.get("type") == "complex":
        return complex(value["re"], value["im"])
    if isinstance(value, dict) and "type" in value:
        cls = _TYPES[value["type"]]
        return cls(**{k: _typed(v) for k, v in value.items() if k != "type"})
    if isinstance(value, list):
        return tuple(_typed(v) for v in value)
    return value


def _order_out(order: RunOrder) -> dict[str, Any]:
    return {
        "id": order.id,
        "spec": _spec_out(order.spec),
        "pace": order.pace,
        "mode": order.mode,
        "experiment": order.experiment,
        "request": order.request,
        "owner": order.owner,
        "private": order.private,
    }


def _order_in(data: dict[str, Any]) -> RunOrder:
    return RunOrder(
        id=data["id"],
        spec=_spec_in(data["spec"]),
        pace=data["pace"],
        mode=data["mode"],
        experiment=data["experiment"],
        request=data["request"],
        owner=data["owner"],
        private=data["private"],
    )


def _record_in(data: dict[str, Any]) -> RunRecord:
    return RunRecord(**{**data, "channels": tuple(tuple(c) for c in data["channels"])})


# -- events -------------------------------------------------------------------------
def _blocks_out(blocks: list[Block]) -> bytes:
    groups = [[b.run_ids, b.k0, int(b.data.shape[1]), int(b.data.shape[2])] for b in blocks]
    payload = b"".join(np.ascontiguousarray(b.data, dtype="<f8").tobytes() for b in blocks)
    return _frame({"ev": "blocks", "groups": groups}, payload)


def _blocks_in(header: dict[str, Any], payload: bytes) -> list[Block]:
    out, at = [], 0
    for run_ids, k0, n, ncols in header["groups"]:
        size = len(run_ids) * n * ncols * 8
        data = np.frombuffer(payload, "<f8", count=size // 8, offset=at).reshape(
            len(run_ids), n, ncols
        )
        out.append(Block(run_ids, k0, data))
        at += size
    return out


def _changed_out(change: Changed) -> dict[str, Any]:
    return {
        "ev": "changed",
        "run": change.run_id,
        "state": change.state.value,
        "k": change.k,
        "error": change.error,
        "compute": change.compute,
    }


def _changed_in(h: dict[str, Any]) -> Changed:
    return Changed(h["run"], RunState(h["state"]), h["k"], h["error"], h.get("compute"))


def _health_in(h: dict[str, Any]) -> Health:
    fields = {k: v for k, v in h.items() if k != "ev"}
    rig = RigLink(**fields["rig"]) if fields.get("rig") is not None else None
    return Health(**{**fields, "store": StoreHealth(**fields["store"]), "rig": rig})


# -- errors ---------------------------------------------------------------------------
def _error_out(exc: ElabError) -> dict[str, Any]:
    out: dict[str, Any] = {"type": type(exc).__name__, "message": str(exc)}
    if isinstance(exc, InvalidInput):
        out.update(field=exc.field, value=_json_safe(exc.value), allowed=exc.allowed)
    elif isinstance(exc, NotFound):
        out.update(kind=exc.kind, id=exc.id)
    elif isinstance(exc, Unavailable):
        out.update(retry_after=exc.retry_after)
    return out


def _error_in(e: dict[str, Any]) -> ElabError:
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
