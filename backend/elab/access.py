"""Who may do what: identities, roles and the rules on owned objects.

An :class:`Identity` is whoever a request comes from: a browser's anonymous
identity (``a-…``), an instructor (``i-<name>``), either of them through an API
token they created. Runs (and later data sets and controllers) record their
owner's id; the rules below are the only place that decides what others may do
with them:

- everyone may watch and download a run, unless it is private;
- only its owner or an instructor may pause, resume, stop, change or delete it,
  and see it when it is private.

A run without an owner (made before owners existed) is controlled by
instructors only.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from elab.errors import Forbidden


class Role(StrEnum):
    STUDENT = "student"
    INSTRUCTOR = "instructor"


ANONYMOUS = "a-"
INSTRUCTOR = "i-"


@dataclass(frozen=True)
class Identity:
    """``id``: what owned objects record; ``via``: how the request proved it ("cookie",
    "session", "token"; "none" for a connection that brought no identity, which may
    only watch)."""

    id: str
    role: Role = Role.STUDENT
    via: str = "cookie"

    @property
    def instructor(self) -> bool:
        return self.role is Role.INSTRUCTOR

    @property
    def name(self) -> str:
        return display_name(self.id)


NOBODY = Identity("", via="none")


def display_name(owner: str | None) -> str:
    """How an owner is shown to others: ``guest 3f2a`` for an anonymous browser, the
    account name for an instructor."""
    if not owner:
        return "no one (an older run, from before owners)"
    if owner.startswith(INSTRUCTOR):
        return owner[len(INSTRUCTOR) :] + " (instructor)"
    if owner.startswith(ANONYMOUS):
        return "guest " + owner[len(ANONYMOUS) : len(ANONYMOUS) + 4]
    return owner


def may_control(who: Identity, owner: str | None) -> bool:
    return who.instructor or (bool(owner) and who.id == owner)


def may_view(who: Identity, owner: str | None, private: bool) -> bool:
    return not private or may_control(who, owner)


def require_control(who: Identity, owner: str | None, what: str, action: str) -> None:
    """:class:`Forbidden` unless ``who`` may ``action`` ``what`` (e.g. "run r-1", "stop")."""
    if not may_control(who, owner):
        raise Forbidden(
            f"{what} belongs to {display_name(owner)}: only its owner or an instructor may "
            f"{action} it (you are {who.name if who.id else 'not identified'})"
        )
