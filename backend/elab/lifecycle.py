"""The run state machine (Starlette's ``WebSocketState`` style): an enum and its
legal transitions; an illegal one raises :class:`~elab.errors.Conflict`.

::

    created → running ⇄ paused → finished | stopped | failed
    (created | running | paused) → interrupted   (found after a server crash)
"""

from __future__ import annotations

from enum import StrEnum

from elab.errors import Conflict


class RunState(StrEnum):
    CREATED = "created"
    RUNNING = "running"
    PAUSED = "paused"
    FINISHED = "finished"
    STOPPED = "stopped"
    FAILED = "failed"
    INTERRUPTED = "interrupted"

    @property
    def live(self) -> bool:
        """Still stepping or able to step again."""
        return self in (RunState.CREATED, RunState.RUNNING, RunState.PAUSED)


_NEXT: dict[RunState, frozenset[RunState]] = {
    RunState.CREATED: frozenset(
        {RunState.RUNNING, RunState.STOPPED, RunState.FAILED, RunState.INTERRUPTED}
    ),
    RunState.RUNNING: frozenset(
        {
            RunState.PAUSED,
            RunState.FINISHED,
            RunState.STOPPED,
            RunState.FAILED,
            RunState.INTERRUPTED,
        }
    ),
    RunState.PAUSED: frozenset(
        {RunState.RUNNING, RunState.STOPPED, RunState.FAILED, RunState.INTERRUPTED}
    ),
}


def transition(current: RunState, new: RunState) -> RunState:
    """``new`` if the machine allows ``current → new``, else :class:`Conflict`."""
    if new not in _NEXT.get(current, frozenset()):
        allowed = ", ".join(sorted(s.value for s in _NEXT.get(current, frozenset()))) or "none"
        raise Conflict(f"run is {current.value}: cannot become {new.value} (allowed: {allowed})")
    return new
