"""Shape checks for state-space matrices, shared by the design modules.

Each returns a clean float64 array or raises :class:`~elab.errors.InvalidInput`
(:class:`~elab.errors.DimensionError` for shapes) naming the field.
"""

from __future__ import annotations

from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from elab.errors import DimensionError, InvalidInput
from elab.validate import finite_array

Matrix = NDArray[np.float64]
ComplexVector = NDArray[np.complex128]
_Array = TypeVar("_Array", bound=NDArray[Any])


def readonly(arr: _Array) -> _Array:
    """``arr`` made read-only, so a frozen result cannot be changed through it."""
    arr.setflags(write=False)
    return arr


def square(field: str, value: Any) -> Matrix:
    """A finite n×n matrix (a scalar counts as 1×1)."""
    arr = finite_array(field, value)
    arr = arr.reshape(1, 1) if arr.ndim == 0 else arr
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise DimensionError(field, value, f"a square n×n matrix, got shape {arr.shape}")
    return arr


def columns(field: str, value: Any, rows: int) -> Matrix:
    """A finite matrix with ``rows`` rows (a 1-D array of that length is one column)."""
    arr = finite_array(field, value)
    arr = arr.reshape(rows, 1) if arr.ndim == 1 and arr.size == rows else arr
    if arr.ndim != 2 or arr.shape[0] != rows:
        raise DimensionError(field, value, f"a matrix with {rows} rows, got shape {arr.shape}")
    return arr


def rows(field: str, value: Any, cols: int) -> Matrix:
    """A finite matrix with ``cols`` columns (a 1-D array of that length is one row)."""
    arr = finite_array(field, value)
    arr = arr.reshape(1, cols) if arr.ndim == 1 and arr.size == cols else arr
    if arr.ndim != 2 or arr.shape[1] != cols:
        raise DimensionError(field, value, f"a matrix with {cols} columns, got shape {arr.shape}")
    return arr


def shaped(field: str, value: Any, shape: tuple[int, int]) -> Matrix:
    """A finite matrix of exactly ``shape`` (a scalar fills a 1×1)."""
    arr = finite_array(field, value)
    arr = arr.reshape(shape) if arr.size == shape[0] * shape[1] and arr.ndim < 2 else arr
    if arr.shape != shape:
        raise DimensionError(field, value, f"shape {shape[0]}×{shape[1]}, got {arr.shape}")
    return arr


def complex_vector(field: str, value: Any) -> ComplexVector:
    """A non-empty 1-D array of finite complex numbers."""
    try:
        arr = np.array(value, dtype=np.complex128)
    except (TypeError, ValueError):
        raise InvalidInput(field, value, "a list of real or complex numbers") from None
    arr = arr.reshape(1) if arr.ndim == 0 else arr
    if arr.ndim != 1 or arr.size == 0:
        raise DimensionError(field, value, f"a non-empty 1-D list, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInput(field, value, "finite numbers (no NaN or infinity)")
    return arr


def sort_eigenvalues(values: ComplexVector) -> ComplexVector:
    """Eigenvalues by real part, largest first, then by imaginary part, largest first."""
    values = np.asarray(values, dtype=np.complex128)
    return values[np.lexsort((-values.imag, -values.real))]
