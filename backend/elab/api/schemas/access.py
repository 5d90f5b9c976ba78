"""Who may do what: the caller's identity, instructor sign-in, API tokens and the pinned
class demo."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from elab.api.schemas.base import Model
from elab.api.schemas.runs import RunSummaryInfo


class Me(Model):
    """Who the server takes the caller for."""

    id: str | None = Field(description="what owned objects record (null: no identity)")
    name: str = Field(description="as others see it")
    role: Literal["student", "instructor"]
    via: Literal["cookie", "session", "token", "none"] = Field(
        description="cookie: the browser's anonymous identity; session: an instructor "
        "signed in; token: an API token"
    )
    account: str | None = Field(description="the instructor account's name (null: none)")
    sign_in: bool = Field(description="this server has instructor accounts to sign in to")


class SignIn(Model):
    name: str = Field(min_length=1, max_length=40)
    password: str = Field(min_length=1, max_length=200)


class TokenCreate(Model):
    name: str = Field(min_length=1, max_length=60, description="what it is for")


class TokenInfo(Model):
    id: str
    name: str
    created_at: float
    last_used: float | None


class TokenCreated(TokenInfo):
    token: str = Field(description="send as Authorization: Bearer <token>; shown once, never again")


class DemoPin(Model):
    run_id: str = Field(min_length=1, max_length=64)


class DemoInfo(Model):
    """The class demo an instructor pinned (``run`` null: none)."""

    run: RunSummaryInfo | None
    pinned_by: str | None = None
    pinned_at: float | None = None
