"""Errors of E-Lab: one root, subclasses that also inherit the matching built-in.

Every message names the field, the offending value and what is allowed, so the
CLI, the API and a notebook user all learn what to change.
"""

from __future__ import annotations

from typing import Any


class ElabError(Exception):
    """Root of every error E-Lab raises on purpose."""


class InvalidInput(ElabError, ValueError):
    """A value given by the user is outside what is allowed.

    Parameters
    ----------
    field : str
        Dotted name of the offending field, e.g. ``"controller.K"``.
    value : Any
        The value received (shown abbreviated).
    allowed : str
        What would have been accepted, in words.
    """

    def __init__(self, field: str, value: Any, allowed: str) -> None:
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{field}: got {_short(value)}; allowed: {allowed}")

    def __reduce__(self) -> tuple[Any, ...]:  # pickled between a worker process and the server
        return type(self), (self.field, self.value, self.allowed)


class DimensionError(InvalidInput):
    """An array has the wrong shape (python-control's ``ControlDimension``)."""


class NotFound(ElabError, LookupError):
    """An id (plant, run, controller) that does not exist."""

    def __init__(self, kind: str, id_: str, known: list[str] | None = None) -> None:
        self.kind = kind
        self.id = id_
        hint = f"; known: {', '.join(known)}" if known else ""
        self.known = known
        super().__init__(f"unknown {kind} {id_!r}{hint}")

    def __reduce__(self) -> tuple[Any, ...]:
        return type(self), (self.kind, self.id, self.known)

    def __str__(self) -> str:  # LookupError would quote the message like a key
        return str(self.args[0])


def _short(value: Any, limit: int = 80) -> str:
    text = _readable(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _readable(value: Any, items: int = 8) -> str:
    """A value as a user would write it: numbers plainly (−8+6j, not ``(-8+6j)``), arrays
    and sequences as lists (not ``array([ -8.+6.j, …])``), nothing as "nothing"."""
    if value is None:
        return "nothing"
    if hasattr(value, "tolist") and callable(value.tolist):  # numpy arrays and scalars
        return _readable(value.tolist(), items)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, complex) and value.imag == 0:
        return _readable(value.real)
    if isinstance(value, complex):
        re, im = _readable(value.real), _readable(abs(value.imag))
        return f"{re}{'-' if value.imag < 0 else '+'}{im}j"
    if isinstance(value, float):
        return repr(int(value)) if value.is_integer() and abs(value) < 1e15 else repr(value)
    if isinstance(value, list | tuple):
        shown = [_readable(v, items) for v in value[:items]]
        more = ", …" if len(value) > items else ""
        return (
            f"[{', '.join(shown)}{more}] ({len(value)} values)" if more else f"[{', '.join(shown)}]"
        )
    return repr(value)


class Conflict(ElabError, RuntimeError):
    """The request conflicts with the current state (a finished run, a busy rig)."""


class TooMany(ElabError, RuntimeError):
    """A limit on concurrent work is reached (e.g. live runs): HTTP 429. ``retry_after``
    (s): when trying again may succeed."""

    def __init__(self, message: str, retry_after: float = 5.0) -> None:
        self.retry_after = retry_after
        super().__init__(message)

    def __reduce__(self) -> tuple[Any, ...]:
        return type(self), (str(self), self.retry_after)


class Unavailable(ElabError, RuntimeError):
    """A part the request needs is down or failing (the engine, the store): HTTP 503.

    ``retry_after`` (s) says when trying again makes sense, if known.
    """

    def __init__(self, message: str, retry_after: float | None = None) -> None:
        self.retry_after = retry_after
        super().__init__(message)


class Forbidden(ElabError, PermissionError):
    """The caller may not do this to this object (someone else's run): HTTP 403."""


class Unauthorized(ElabError, PermissionError):
    """The credentials given are not valid (an unknown or revoked token, a wrong
    password): HTTP 401."""
