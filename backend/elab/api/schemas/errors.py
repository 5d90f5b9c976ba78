"""The error body every failed request answers with (REST)."""

from __future__ import annotations

from typing import Literal

from elab.api.schemas.base import Model


class FieldError(Model):
    field: str
    message: str


ErrorCode = Literal[
    "invalid",
    "not_found",
    "conflict",
    "too_many",
    "too_large",
    "unavailable",
    "forbidden",
    "unauthorized",
    "unsupported_media_type",
    "timeout",
]


class ErrorDetail(Model):
    code: ErrorCode
    message: str
    field: str | None = None
    errors: list[FieldError] = []


class ErrorBody(Model):
    error: ErrorDetail
