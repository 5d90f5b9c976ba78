"""Checks for user-given numbers, shared by design and simulation.

Each returns a clean float64 array or float, or raises
:class:`~elab.errors.InvalidInput` naming the field, the value and what is allowed.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elab.errors import DimensionError, ElabError, InvalidInput

# what numpy, scipy and python-control raise when a computation meets numbers it cannot
# carry (an overflow to inf, a division by an underflowed zero, a matrix left non-finite)
_NUMERIC = (ArithmeticError, np.linalg.LinAlgError)
_NUMERIC_WORDS = ("inf", "nan", "finite", "ill-conditioned", "singular", "did not converge")


def finite_array(
    field: str, value: Any, shape: Sequence[int | None] | None = None
) -> NDArray[np.float64]:
    """``value`` as a finite float64 array of ``shape`` (``None`` = any length there)."""
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInput(field, value, "an array of real numbers") from None
    if shape is not None and not _shape_matches(arr.shape, shape):
        want_text = "×".join("n" if s is None else str(s) for s in shape)
        raise DimensionError(field, value, f"shape {want_text}, got {arr.shape}")
    if arr.size == 0:
        raise InvalidInput(field, value, "a non-empty array")
    if not np.all(np.isfinite(arr)):
        raise InvalidInput(field, value, "finite numbers (no NaN or infinity)")
    return arr


def finite_float(
    field: str,
    value: Any,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
) -> float:
    """``value`` as a finite float within ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise InvalidInput(field, value, "a real number")
    x = float(value)
    allowed = _range_text(lo, hi, lo_open)
    if not np.isfinite(x):
        raise InvalidInput(field, value, f"a finite number{allowed}")
    if lo is not None and (x < lo or (lo_open and x == lo)):
        raise InvalidInput(field, value, f"a number{allowed}")
    if hi is not None and x > hi:
        raise InvalidInput(field, value, f"a number{allowed}")
    return x


def _shape_matches(got: tuple[int, ...], want: Sequence[int | None]) -> bool:
    same = len(got) == len(want)
    return same and all(w is None or g == w for g, w in zip(got, want, strict=True))


def _range_text(lo: float | None, hi: float | None, lo_open: bool) -> str:
    if lo is None and hi is None:
        return ""
    if hi is None:
        return f" {'>' if lo_open else '≥'} {lo:g}"
    if lo is None:
        return f" ≤ {hi:g}"
    return f" in {'(' if lo_open else '['}{lo:g}, {hi:g}]"


@contextmanager
def computable(field: str, value: Any, allowed: str) -> Iterator[None]:
    """Run a computation on numbers a client gave: where they make it fail (issue 24: K =
    1e308 overflowed a discretisation, a time constant of 5e-324 divided by zero, Q = 1e154
    made a Riccati solver give up), :class:`InvalidInput` naming ``field`` and saying what
    is ``allowed``, instead of an internal error. Errors of E-Lab's own pass through."""
    try:
        yield
    except ElabError:
        raise
    except _NUMERIC as exc:
        raise InvalidInput(field, value, f"{allowed} ({_reason(exc)})") from None
    except ValueError as exc:
        if not any(word in str(exc).lower() for word in _NUMERIC_WORDS):
            raise
        raise InvalidInput(field, value, f"{allowed} ({_reason(exc)})") from None


def finite_result(field: str, value: Any, allowed: str, *arrays: Any) -> None:
    """:class:`InvalidInput` for ``field`` unless every one of ``arrays`` is finite: what a
    client's numbers gave overflowed."""
    for a in arrays:
        if not np.all(np.isfinite(np.asarray(a, dtype=np.complex128))):
            raise InvalidInput(field, value, f"{allowed} (the arithmetic overflowed)")


def _reason(exc: Exception) -> str:
    text = str(exc).split("\n")[0][:120] or type(exc).__name__
    return f"the arithmetic failed: {text}"
