"""The building blocks of every wire model: the strict ``Model`` base, finite numbers,
complex numbers, result numbers (``Num``) and matrices."""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict

PROTOCOL = "elab.v1"
Finite = float  # with allow_inf_nan=False below, NaN and ±inf are refused everywhere


class Model(BaseModel):
    """Strict: a value is taken only in the JSON type its schema names (``true`` is not a
    number, ``"1"`` not an integer), so what the OpenAPI document accepts and what the
    server accepts are the same set."""

    model_config = ConfigDict(
        extra="forbid",
        allow_inf_nan=False,
        frozen=True,
        strict=True,
        json_schema_serialization_defaults_required=True,
        # each model's validator is built when it is first used, not at import: the
        # server answers its first request 0.3 s sooner (docs/benchmarks.md, start-up)
        defer_build=True,
    )


class Complex(Model):
    re: float
    im: float


def _finite_or_none(value: Any) -> Any:
    return None if isinstance(value, float) and not math.isfinite(value) else value


#: A result number: ``null`` where it is not finite (a fit of −∞ on a constant output).
Num = Annotated[float | None, BeforeValidator(_finite_or_none)]
Matrix = list[list[float]]
