"""Live changes, decided on typed values: what a run's loop uses now, what a new law or
reference alters in it field by field, and whether anything does (the answer of
``POST /runs/{id}/params`` and of the stream's ``set_params``).

Fields are named as in a run's request, a part (``controller``, ``signal``) then the
field and an index per dimension: ``controller.kind``, ``controller.K.1``,
``controller.observer_poles.0.re``, ``signal.amplitude``. Numbers equal to 12 significant
digits count as equal: degrees typed in a form come back as radians a rounding away from
the value the run uses.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field, fields
from typing import Literal

from elab.engines.base import NewParams
from elab.errors import InvalidInput
from elab.laws import ControlLaw, is_code, law_kind
from elab.sim.signals import Signal, signal_kind
from elab.store.base import JsonObject

Scalar = float | int | str | bool | None
Part = Literal["controller", "signal"]
#: the part each key of a change as asked belongs to (an uploaded controller's id goes with
#: the law it brought)
PART_OF: dict[str, Part] = {
    "controller": "controller",
    "controller_id": "controller",
    "signal": "signal",
}


@dataclass(frozen=True)
class RunParams:
    """What a live run's loop uses: its control law and its reference."""

    law: ControlLaw
    reference: Signal

    def after(self, new: NewParams) -> RunParams:
        """What it uses once ``new`` is applied (a part ``None`` there stays)."""
        law = self.law if new.law is None else new.law
        return RunParams(law, self.reference if new.reference is None else new.reference)


@dataclass(frozen=True)
class Change:
    """A live change as asked: a new law and/or reference (``None``: keep it);
    ``controller_id``, the uploaded controller the law comes from; ``asked``, the change
    as its client sent it (keys ``controller``, ``controller_id``, ``signal``), recorded with
    the parts that alter something. A Python controller is refused here: it runs from the
    start of a run, never swapped into a live one."""

    law: ControlLaw | None = None
    reference: Signal | None = None
    controller_id: str | None = None
    asked: JsonObject = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.law is not None and is_code(self.law):
            raise InvalidInput(
                "controller_id",
                self.controller_id,
                "a declarative controller: a Python controller runs from the start of a "
                "run (POST /runs with its controller_id), not swapped into a live one",
            )


@dataclass(frozen=True)
class Difference:
    """One value a change alters: ``field`` as in a request (``controller.K.1``), ``None``
    where a value is not set."""

    field: str
    before: Scalar
    after: Scalar


@dataclass(frozen=True)
class Decision:
    """What a change does to a run: ``new``, the parts that alter something (for the
    engine; ``None``: nothing differs, nothing is applied or recorded), and ``changed``,
    every value they alter."""

    new: NewParams | None
    changed: tuple[Difference, ...]


@dataclass(frozen=True)
class Applied:
    """A change as applied: ``k``, the first sample with it (when nothing differed, the
    sample the run has reached), and what it altered."""

    k: int
    changed: tuple[Difference, ...] = ()


def decide(now: RunParams, change: Change) -> Decision:
    """The parts of ``change`` that alter what the run uses ``now``, field by field. A run
    with a Python controller takes a new reference, never a new law."""
    if change.law is not None and is_code(now.law):
        raise InvalidInput(
            "controller",
            change.controller_id or law_kind(change.law),
            "a declarative law on a run with one: a Python controller cannot be swapped in "
            "or out mid-run; start a new run",
        )
    law = () if change.law is None else law_differences(now.law, change.law)
    ref = () if change.reference is None else signal_differences(now.reference, change.reference)
    if not law and not ref:
        return Decision(None, ())
    kept = {"controller": bool(law), "signal": bool(ref)}
    new = NewParams(
        change.law if law else None,
        change.reference if ref else None,
        {key: value for key, value in change.asked.items() if kept[PART_OF[key]]},
    )
    return Decision(new, law + ref)


def law_differences(before: ControlLaw, after: ControlLaw) -> tuple[Difference, ...]:
    """The fields of law ``after`` that differ from ``before``, as ``controller.…``."""
    return differences(
        flat("controller", law_kind(before), before), flat("controller", law_kind(after), after)
    )


def signal_differences(before: Signal, after: Signal) -> tuple[Difference, ...]:
    """The fields of signal ``after`` that differ from ``before``, as ``signal.…``."""
    return differences(
        flat("signal", signal_kind(before), before), flat("signal", signal_kind(after), after)
    )


def differences(
    before: Iterable[tuple[str, Scalar]], after: Iterable[tuple[str, Scalar]]
) -> tuple[Difference, ...]:
    """The fields of ``after`` whose values differ from ``before``'s, then those only
    ``before`` has."""
    old, new = dict(before), dict(after)
    keys = list(new) + [k for k in old if k not in new]
    return tuple(
        Difference(k, old.get(k), new.get(k)) for k in keys if not same(old.get(k), new.get(k))
    )


def flat(part: Part, kind: str, value: ControlLaw | Signal) -> Iterator[tuple[str, Scalar]]:
    """A law or signal as ``(field, value)`` pairs: its kind, then its fields in order."""
    yield f"{part}.kind", kind
    for f in fields(value):
        yield from _values(f"{part}.{f.name}", getattr(value, f.name))


def _values(path: str, value: object) -> Iterator[tuple[str, Scalar]]:
    match value:
        case tuple():
            for i, v in enumerate(value):
                yield from _values(f"{path}.{i}", v)
        case complex():  # an observer's pole
            yield f"{path}.re", value.real
            yield f"{path}.im", value.imag
        case None | bool() | int() | float() | str():
            yield path, value
        case _:
            raise TypeError(f"{path}: {type(value).__name__} is not a value of a law or signal")


def same(a: Scalar, b: Scalar) -> bool:
    """Equal values: numbers to 12 significant digits (``True`` is not ``1``)."""
    if isinstance(a, int | float) and isinstance(b, int | float) and bool not in (type(a), type(b)):
        return math.isclose(a, b, rel_tol=1e-12)
    return type(a) is type(b) and a == b
