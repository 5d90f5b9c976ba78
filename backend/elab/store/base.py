"""What the lab keeps about runs, and the protocol every store implements.

A run's recording is a float64 array ``(n, nch)`` whose columns are the run's
channels (``r, u, y…, x…``); row ``k`` is sample ``k`` at time ``k·Ts``. It
arrives in consecutive chunks. Records and samples are written by the engine
that steps the run (it owns the run: ``engine``) and read by anyone.

Failures are :class:`StoreError`: ``transient`` ones (another writer holds the
lock) are worth retrying; the others (disk full, read-only or damaged file, I/O
error) are not until an operator acts.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from elab.errors import Unavailable
from elab.rig_queue import QueueChange, QueueOp, QueuePolicy, RigQueue

Array = NDArray[np.float64]

#: A JSON document the lab keeps and shows as it was given, never reading into it: a run's
#: request (as the client sent it, the defaults filled in) and a live change as asked. The
#: API writes and reads these (their schema is the wire's); the core carries them opaque
#: and works on the typed values beside them (``RunOrder.spec``, a change's law).
JsonObject = dict[str, Any]


class StoreError(Unavailable):
    """The store could not do what was asked. ``transient``: retrying may succeed soon
    (a lock held by another writer); otherwise it fails until someone acts (space, file
    permissions, a damaged file)."""

    def __init__(self, message: str, *, transient: bool) -> None:
        self.transient = transient
        super().__init__(f"the run store failed: {message}", retry_after=1.0 if transient else None)


@dataclass(frozen=True, kw_only=True)
class RunSummary:
    """What the store keeps about a run besides its samples and its request (times in unix
    seconds)."""

    id: str
    plant: str
    mode: str  # "simulation" | "rig"
    experiment: str  # "analysis" | "identification" | "design"
    status: str  # a RunState value
    Ts: float  # s
    channels: tuple[tuple[str, str], ...]  # (name, unit) of the recorded columns
    n_planned: int  # samples of the run if it completes
    n_stored: int = 0  # samples stored so far (maintained by the store)
    created_at: float = 0.0
    started_at: float | None = None
    finished_at: float | None = None
    error: str | None = None  # why it failed, stopped early or was interrupted
    engine: str | None = None  # the engine that steps (or stepped) it
    owner: str | None = None  # the identity that started it (elab.access); None: before owners
    private: bool = False  # only its owner and instructors may see it
    # a code controller's compute time per step (steps, median_us, p99_us, max_us, misses)
    compute: dict[str, float | int] | None = None
    # what a "finished" alone would hide (elab.engines.outcome): kind, k, t, text each;
    # None: not known (a live run, or one recorded before outcomes were kept)
    outcome: list[dict[str, Any]] | None = None


@dataclass(frozen=True, kw_only=True)
class RunRecord(RunSummary):
    """A run with the request it was started from (as the client sent it with the
    defaults filled in)."""

    spec: JsonObject = field(default_factory=dict)


@dataclass(frozen=True)
class ParamChange:
    """New parameters of a run, in force from sample ``k`` on (``at`` in unix seconds):
    ``params``, the change as its client asked it (the parts that altered something)."""

    k: int
    params: JsonObject
    at: float


@dataclass(frozen=True)
class Usage:
    """An owner's runs in the store: how many, and their samples' bytes (8 per value)."""

    runs: int
    bytes: int


@dataclass(frozen=True)
class Token:
    """An API token as kept: never the token itself, only its SHA-256 (``hash``)."""

    id: str
    owner: str
    name: str
    created_at: float
    last_used: float | None = None


@dataclass(frozen=True)
class Pin:
    """A run pinned under ``name`` (the class demo) by ``owner`` at ``at``."""

    name: str
    run_id: str
    owner: str
    at: float


@dataclass(frozen=True)
class StoredController:
    """A controller a user uploaded: ``law`` as the fields of a controller file (JSON-able),
    ``report`` its validation report (JSON-able), ``source`` the file as sent."""

    id: str
    owner: str
    plant: str
    name: str
    format: str
    law: dict[str, Any]
    report: dict[str, Any]
    created_at: float
    source: bytes = b""


class ControllerStore(Protocol):
    """Uploaded controllers, by owner."""

    def add_controller(self, controller: StoredController) -> None: ...

    def get_controller(self, controller_id: str) -> StoredController:
        """:class:`NotFound` for an unknown id."""

    def list_controllers(
        self, owner: str | None, plant: str | None = None
    ) -> list[StoredController]:
        """Newest first, without their sources; ``owner`` None: everyone's."""

    def count_controllers(self, owner: str) -> int: ...

    def delete_controller(self, controller_id: str) -> None:
        """:class:`NotFound` for an unknown id."""


@dataclass(frozen=True)
class StoredModel:
    """An identified model a user kept for design: ``model`` is its JSON-able document
    (``Ts``, ``A``, ``B``, ``C``, ``D``, names and units of input and outputs, where it
    came from, its fit; api/models.py says which fields)."""

    id: str
    owner: str
    plant: str
    name: str
    model: dict[str, Any]
    created_at: float


class ModelStore(Protocol):
    """Identified models kept for design, by owner; anyone with a model's id may read it
    (its link is shared), only its owner or an instructor deletes it (the API decides)."""

    def add_model(self, model: StoredModel) -> None: ...

    def get_model(self, model_id: str) -> StoredModel:
        """:class:`NotFound` for an unknown id."""

    def list_models(self, owner: str | None, plant: str | None = None) -> list[StoredModel]:
        """Newest first (at most 1000); ``owner`` None: everyone's."""

    def count_models(self, owner: str) -> int: ...

    def delete_model(self, model_id: str) -> None:
        """:class:`NotFound` for an unknown id."""


class AccessStore(Protocol):
    """API tokens, pinned runs and ended sessions (identities themselves are not stored: an
    anonymous one lives in its browser's signed cookie, instructors in the server's
    configuration)."""

    def add_token(self, token: Token, digest: str) -> None: ...

    def token_by_digest(self, digest: str) -> Token | None:
        """The token whose SHA-256 is ``digest``, if any."""

    def touch_token(self, token_id: str, at: float) -> None:
        """Record a use of the token (``last_used``)."""

    def tokens(self, owner: str) -> list[Token]: ...

    def revoke_token(self, owner: str, token_id: str) -> None:
        """:class:`NotFound` if ``owner`` has no token ``token_id``."""

    def set_pin(self, pin: Pin) -> None: ...

    def pin(self, name: str) -> Pin | None: ...

    def clear_pin(self, name: str) -> None: ...

    def end_session(self, sid: str, until: float) -> None:
        """Session ``sid`` is over (signed out); it would have expired at ``until`` (unix s),
        after which its record may go."""

    def ended_sessions(self, now: float) -> set[str]:
        """The sessions ended and not yet expired at ``now``."""


class RigQueueStore(Protocol):
    """The queue of each rig (:mod:`elab.rig_queue`), kept across restarts. One operation
    is one write transaction: the queue is read, the pure rule applied at ``now`` (s, the
    caller's clock) and the result written before any other writer (thread or process)
    reads it, so two drivers at once cannot happen, whatever the timing."""

    def rig_queue(self, rig: str, policy: QueuePolicy, now: float) -> RigQueue:
        """The queue of ``rig`` at ``now`` (expired slots and no-shows applied, and
        written if that changed anything). A rig never seen has an empty queue."""

    def apply_rig(self, rig: str, op: QueueOp, policy: QueuePolicy, now: float) -> QueueChange:
        """Apply ``op`` at ``now`` atomically; :class:`~elab.errors.Conflict` (nothing
        written) if the rules refuse it. ``stop_run`` of the result: the run the caller must
        stop now (the rig engine also stops any run that is not the queue's ``running``)."""


class RunStore(Protocol):
    """Runs, their parameter changes and their samples. Every method is safe to call from
    any thread; each write is a transaction of its own (all or nothing)."""

    def create_run(self, record: RunRecord) -> None: ...

    def set_status(
        self,
        run_id: str,
        status: str,
        *,
        started_at: float | None = None,
        finished_at: float | None = None,
        error: str | None = None,
        compute: dict[str, float | int] | None = None,
        outcome: list[dict[str, Any]] | None = None,
    ) -> None:
        """Set ``status`` and those of the other fields that are given."""

    def get_run(self, run_id: str) -> RunRecord: ...

    def list_runs(
        self,
        *,
        plant: str | None = None,
        owner: str | None = None,
        viewer: str | None = None,
        limit: int = 50,
        offset: int = 0,
    ) -> tuple[list[RunSummary], int]:
        """A page of runs, newest first, and how many match in all: of ``plant`` and of
        ``owner`` if given; ``viewer`` given, private runs only of that owner (``None``:
        every run, as an instructor sees them)."""

    def delete_run(self, run_id: str) -> None:
        """Remove an ended run with its samples and changes (:class:`Conflict` if live)."""

    def usage(self, owner: str) -> Usage:
        """What ``owner``'s runs hold in the store."""

    def ended_before(self, t: float, limit: int = 100) -> list[str]:
        """Ended runs that finished before ``t`` (unix s), oldest first, not pinned."""

    def mark_interrupted(self, engine: str, reason: str) -> list[str]:
        """Every run of ``engine`` still created, running or paused becomes interrupted
        (``error``: ``reason``); returns their ids. Runs of other engines are left alone."""

    def add_param_change(self, run_id: str, change: ParamChange) -> None: ...

    def param_changes(self, run_id: str) -> list[ParamChange]:
        """The run's parameter changes ordered by ``k`` (then by arrival)."""

    def append_many(self, items: list[tuple[str, int, Array]]) -> None:
        """Store chunks ``(run id, k0, rows)`` in one transaction: all or none. ``k0`` must
        be the number of samples stored so far of that run."""

    def read(self, run_id: str, k0: int = 0, k1: int | None = None) -> Array:
        """Rows ``[k0, min(k1, n_stored))`` as a new ``(n, nch)`` array."""

    def probe(self) -> None:
        """A small real write: raises :class:`StoreError` if writing fails now."""

    def close(self) -> None: ...
