"""Identities over HTTP: who am I, instructor sign-in, API tokens, the class demo.

See :mod:`elab.api.auth` for how a request's identity is found and
docs/access.md for the whole picture.
"""

from __future__ import annotations

import asyncio
import time

from starlette.requests import Request
from starlette.responses import Response

from elab.access import Identity, display_name
from elab.api import schemas as s
from elab.api.auth import (
    ID_COOKIE,
    SESSION_COOKIE,
    Authority,
    cookies_of,
    identity,
    me_fields,
    session_cookie_value,
)
from elab.api.http import endpoint, ok, read_model, within_budget
from elab.api.runs import manager, run_summary
from elab.api.state import lab
from elab.errors import Forbidden, NotFound
from elab.store.base import Pin

DEMO = "demo"


def authority(request: Request) -> Authority:
    return lab(request).authority


@endpoint("GET", "/me", response=s.Me, errors=())
async def me(request: Request) -> Response:
    """Who the server takes the caller for

    A browser's first request gives it an anonymous identity (a signed cookie); an
    instructor signed in, or an API token, is that identity instead."""
    return ok(s.Me(**me_fields(identity(request), authority(request))))


@endpoint("POST", "/session", body=s.SignIn, response=s.Me, errors=(401, 413, 415, 422, 429, 503))
async def sign_in(request: Request) -> Response:
    """Sign in as an instructor (sets the session cookie)

    Accounts are configured by the operator (``ELAB_INSTRUCTORS``). Five failed
    attempts a minute from one address, then 429."""
    req = await read_model(request, s.SignIn)
    auth = authority(request)
    address = request.client.host if request.client else ""
    value = await asyncio.to_thread(auth.sign_in, req.name, req.password, address)
    who = await auth.session(value)
    assert who is not None
    response = ok(s.Me(**me_fields(who, auth)))
    response.headers.append("set-cookie", session_cookie_value(auth, value))
    return response


@endpoint("DELETE", "/session", response=s.Me, errors=(503,))
async def sign_out(request: Request) -> Response:
    """Sign out (back to the browser's anonymous identity)

    The session ends on the server: its cookie, even kept, no longer signs in."""
    auth = authority(request)
    cookies = cookies_of(request.scope)
    await asyncio.to_thread(auth.sign_out, cookies.get(SESSION_COOKIE))
    who = auth.anonymous(cookies.get(ID_COOKIE)) or Identity("", via="none")
    response = ok(s.Me(**me_fields(who, auth)))
    response.headers.append("set-cookie", session_cookie_value(auth, None))
    return response


def _token_owner(request: Request) -> Identity:
    who = identity(request)
    if not who.id:
        raise Forbidden("an API token belongs to an identity: open the lab in a browser first")
    return who


@endpoint("GET", "/tokens", response=list[s.TokenInfo], errors=())
async def list_tokens(request: Request) -> Response:
    """The caller's API tokens (not the tokens themselves)"""
    who = identity(request)
    tokens = await asyncio.to_thread(authority(request).store.tokens, who.id) if who.id else []
    return ok(
        [
            s.TokenInfo(id=t.id, name=t.name, created_at=t.created_at, last_used=t.last_used)
            for t in tokens
        ]
    )


@endpoint(
    "POST",
    "/tokens",
    body=s.TokenCreate,
    response=s.TokenCreated,
    status=201,
    errors=(403, 413, 415, 422, 429, 503),
    links=(("revoke_token", "token_id"),),
)
async def create_token(request: Request) -> Response:
    """Make an API token that acts as the caller (for scripts and autograders)

    The token is in this answer only; the server keeps its SHA-256. At most
    ``ELAB_MAX_TOKENS_PER_IDENTITY`` (20) per identity. Without credentials the caller is a
    new anonymous identity, which the token then carries: a script's way to one."""
    req = await read_model(request, s.TokenCreate)
    who = _token_owner(request)
    auth = authority(request)
    limit = lab(request).settings.max_tokens_per_identity
    with lab(request).pending.hold("tokens", who.id) as others:
        have = await asyncio.to_thread(auth.store.tokens, who.id)
        within_budget(len(have) + others, limit, "API tokens", "ELAB_MAX_TOKENS_PER_IDENTITY")
        token, raw = await asyncio.to_thread(auth.make_token, who, req.name)
    return ok(
        s.TokenCreated(
            id=token.id, name=token.name, created_at=token.created_at, last_used=None, token=raw
        ),
        status=201,
    )


@endpoint("DELETE", "/tokens/{token_id}", status=204, errors=(404, 503))
async def revoke_token(request: Request) -> Response:
    """Revoke one of the caller's API tokens"""
    who = identity(request)
    token_id = request.path_params["token_id"]
    if not who.id:
        raise NotFound("token", token_id)
    await asyncio.to_thread(authority(request).revoke, who, token_id)
    return Response(status_code=204)


# -- the class demo ------------------------------------------------------------------
@endpoint("GET", "/demo", response=s.DemoInfo, errors=())
async def get_demo(request: Request) -> Response:
    """The run an instructor pinned as the class demo"""
    pin = await asyncio.to_thread(authority(request).store.pin, DEMO)
    if pin is None:
        return ok(s.DemoInfo(run=None))
    try:
        record = await manager(request).get(pin.run_id, identity(request))
    except NotFound:  # private to someone else: not shown
        return ok(s.DemoInfo(run=None))
    return ok(
        s.DemoInfo(
            run=run_summary(record, identity(request)),
            pinned_by=display_name(pin.owner),
            pinned_at=pin.at,
        )
    )


def _instructor(request: Request, action: str) -> Identity:
    who = identity(request)
    if not who.instructor:
        raise Forbidden(f"only an instructor may {action} the class demo (sign in first)")
    return who


@endpoint(
    "PUT", "/demo", body=s.DemoPin, response=s.DemoInfo, errors=(403, 404, 413, 415, 422, 503)
)
async def pin_demo(request: Request) -> Response:
    """Pin a run as the class demo (instructors)"""
    req = await read_model(request, s.DemoPin)
    who = _instructor(request, "pin")
    record = await manager(request).get(req.run_id, who)
    await asyncio.to_thread(
        authority(request).store.set_pin, Pin(DEMO, record.id, who.id, time.time())
    )
    return await get_demo(request)


@endpoint("DELETE", "/demo", status=204, errors=(403, 503))
async def unpin_demo(request: Request) -> Response:
    """Unpin the class demo (instructors)"""
    _instructor(request, "unpin")
    await asyncio.to_thread(authority(request).store.clear_pin, DEMO)
    return Response(status_code=204)
