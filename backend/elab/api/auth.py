"""Who a request comes from (docs/access.md).

Three ways, tried in this order:

1. ``Authorization: Bearer <token>``: an API token (scripts, autograders), made by
   its owner under ``/api/v1/tokens``; it acts as that owner. An unknown or revoked
   token is refused (401), never taken for an anonymous visitor.
2. The ``elab_session`` cookie: an instructor signed in with ``POST /session``
   (accounts in ``ELAB_INSTRUCTORS``; passwords hashed with scrypt), valid for
   ``ELAB_SESSION_HOURS``.
3. The ``elab_id`` cookie: the browser's anonymous identity, given on its first
   request. Both cookies are signed (itsdangerous), HttpOnly and SameSite=Lax.

:class:`Identify` (middleware) puts the :class:`~elab.access.Identity` in the
scope; every handler reads it with :func:`identity`. Single sign-on from a
learning platform (LTI 1.3 launch, OpenID Connect) would be one more way here,
ending in the same session cookie; nothing behind this module changes.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import functools
import hashlib
import hmac
import math
import os
import secrets
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from itsdangerous import BadSignature, Signer, URLSafeTimedSerializer
from starlette.datastructures import MutableHeaders
from starlette.requests import HTTPConnection
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from elab.access import ANONYMOUS, INSTRUCTOR, NOBODY, Identity, Role
from elab.api.http import error_response
from elab.api.state import lab
from elab.errors import ElabError, InvalidInput, TooMany, Unauthorized
from elab.store.base import AccessStore, Token

ID_COOKIE = "elab_id"
SESSION_COOKIE = "elab_session"
SCOPE_KEY = "elab.identity"
TOKEN_PREFIX = "elab_"
ID_MAX_AGE = 400 * 86400  # s: browsers cap a cookie's life at 400 days
SCRYPT = {"n": 2**14, "r": 8, "p": 1}  # RFC 7914's interactive-login parameters
_TOKEN_CACHE_S = 60.0  # a revoked token stops working on this server at once, elsewhere in 60 s


def identity(conn: HTTPConnection) -> Identity:
    """Who the request or websocket comes from (set by :class:`Identify`)."""
    return conn.scope.get(SCOPE_KEY, NOBODY)  # type: ignore[no-any-return]


# -- passwords --------------------------------------------------------------------
def hash_password(password: str, salt: bytes | None = None) -> str:
    """``scrypt$n$r$p$salt$hash`` (base64), for an ``ELAB_INSTRUCTORS`` line."""
    salt = salt or os.urandom(16)
    digest = hashlib.scrypt(password.encode(), salt=salt, dklen=32, **SCRYPT)
    n, r, p = SCRYPT["n"], SCRYPT["r"], SCRYPT["p"]
    b64 = base64.b64encode
    return f"scrypt${n}${r}${p}${b64(salt).decode()}${b64(digest).decode()}"


def check_password(password: str, stored: str) -> bool:
    try:
        kind, n, r, p, salt, digest = stored.split("$")
        if kind != "scrypt":
            return False
        got = hashlib.scrypt(
            password.encode(),
            salt=base64.b64decode(salt),
            n=int(n),
            r=int(r),
            p=int(p),
            dklen=len(base64.b64decode(digest)),
        )
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(got, base64.b64decode(digest))


def read_instructors(path: Path | None) -> dict[str, str]:
    """``name → password hash`` from the accounts file: one ``name:hash`` a line, ``#``
    comments (``elab instructor NAME`` writes a line)."""
    if path is None:
        return {}
    accounts: dict[str, str] = {}
    for i, line in enumerate(path.read_text().splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        name, sep, stored = line.partition(":")
        if not sep or not valid_name(name) or not stored.startswith("scrypt$"):
            raise InvalidInput(
                f"ELAB_INSTRUCTORS line {i}", line[:40], "name:scrypt$… (elab instructor NAME)"
            )
        accounts[name] = stored
    return accounts


def valid_name(name: str) -> bool:
    return 1 <= len(name) <= 40 and name.isascii() and all(c.isalnum() or c in "._-" for c in name)


def load_secret(settings_secret: str | None, data_dir: Path) -> str:
    """The signing key: ``ELAB_SECRET``, else the one kept in the data directory (made on
    first start, readable by the server's user only)."""
    if settings_secret:
        return settings_secret
    path = data_dir / "secret.key"
    if not path.exists():
        data_dir.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w") as f:
            f.write(secrets.token_urlsafe(48))
    return path.read_text().strip()


# -- the authority ----------------------------------------------------------------
@dataclass
class Authority:
    """Signs and checks cookies, knows the instructors, looks tokens up (cached)."""

    secret: str
    store: AccessStore
    instructors: dict[str, str]
    session_s: float = 12 * 3600.0
    secure: bool = False
    _tokens: dict[str, tuple[float, Token | None]] = field(default_factory=dict)
    _failures: dict[str, list[float]] = field(default_factory=dict)
    _ended: set[str] = field(default_factory=set)  # sessions signed out (from the store)
    _ended_read: float = -math.inf  # when _ended was last read from the store (monotonic s)

    def __post_init__(self) -> None:
        self._ids = Signer(self.secret, salt="elab.identity")
        self._sessions = URLSafeTimedSerializer(self.secret, salt="elab.session.2")
        self._signing_in = threading.Lock()

    # cookies
    def new_anonymous(self) -> tuple[Identity, str]:
        ident = Identity(ANONYMOUS + secrets.token_hex(8), Role.STUDENT, "cookie")
        return ident, self._ids.sign(ident.id).decode()

    def anonymous(self, cookie: str | None) -> Identity | None:
        if not cookie:
            return None
        try:
            value = self._ids.unsign(cookie).decode()
        except BadSignature:
            return None
        return Identity(value, Role.STUDENT, "cookie") if value.startswith(ANONYMOUS) else None

    def _session(self, cookie: str | None) -> tuple[str, str, float] | None:
        """The account, the session id and when it was signed (unix s) of a valid session
        cookie (signed, not expired, its account still configured)."""
        if not cookie:
            return None
        try:
            value, signed = self._sessions.loads(
                cookie, max_age=round(self.session_s), return_timestamp=True
            )
        except BadSignature:
            return None
        if not (
            isinstance(value, list) and len(value) == 2 and all(isinstance(v, str) for v in value)
        ):
            return None
        name, sid = value
        if name not in self.instructors:
            return None  # an account removed from the file signs out
        return name, sid, signed.timestamp()

    async def session(self, cookie: str | None) -> Identity | None:
        """The instructor of a session cookie, unless that session was signed out (on any
        server of the lab: the store says so; read at most once a minute, at once here)."""
        found = self._session(cookie)
        if found is None:
            return None
        name, sid, _ = found
        if time.monotonic() - self._ended_read > _TOKEN_CACHE_S:
            self._ended_read = time.monotonic()
            self._ended = await asyncio.to_thread(self.store.ended_sessions, time.time())
        if sid in self._ended:
            return None
        return Identity(INSTRUCTOR + name, Role.INSTRUCTOR, "session")

    def sign_out(self, cookie: str | None) -> None:
        """End the session of ``cookie`` for good: the cookie no longer signs in, even kept
        and sent again (issue 24: a cookie captured before sign-out worked for 12 h)."""
        found = self._session(cookie)
        if found is not None:
            _, sid, signed = found
            self.store.end_session(sid, signed + self.session_s)
            self._ended.add(sid)

    def sign_in(self, name: str, password: str, address: str) -> str:
        """The session cookie's value, or :class:`Unauthorized`; 5 attempts a minute from
        one address without success, then :class:`TooMany` (scrypt makes each guess cost 50
        ms anyway). An attempt counts before its password is checked, so attempts at once
        cannot all pass the limit before the first failure is counted."""
        now = time.monotonic()
        with self._signing_in:
            recent = [t for t in self._failures.get(address, []) if now - t < 60.0]
            if len(recent) >= 5:
                raise TooMany(
                    "5 failed sign-ins from your address in the last minute; wait a minute",
                    retry_after=60.0 - (now - recent[0]),
                )
            self._failures[address] = [*recent, now]
        stored = self.instructors.get(name)
        # a missing account costs the same scrypt as a wrong password
        ok = check_password(password, stored or _dummy()) and stored is not None
        if not ok:
            raise Unauthorized("unknown instructor or wrong password")
        with self._signing_in:
            self._failures.pop(address, None)
        return self._sessions.dumps([name, secrets.token_urlsafe(16)])

    # tokens
    async def token(self, raw: str) -> Identity:
        """The identity a token acts as (looked up in the store at most once a minute, in
        a thread: the store may wait seconds for a lock); :class:`Unauthorized` if none."""
        digest = hashlib.sha256(raw.encode()).hexdigest()
        now = time.monotonic()
        hit = self._tokens.get(digest)
        if hit is None or now - hit[0] > _TOKEN_CACHE_S:
            token = None
            if raw.startswith(TOKEN_PREFIX):
                token = await asyncio.to_thread(self._look_up, digest)
            if len(self._tokens) > 10_000:
                self._tokens.clear()
            self._tokens[digest] = (now, token)
        else:
            token = hit[1]
        if token is None:
            raise Unauthorized(
                "the API token in Authorization is unknown or revoked; make one under "
                "/api/v1/tokens (signed in as its owner)"
            )
        if token.owner.startswith(INSTRUCTOR):
            if token.owner[len(INSTRUCTOR) :] not in self.instructors:
                raise Unauthorized("the token's instructor account no longer exists")
            return Identity(token.owner, Role.INSTRUCTOR, "token")
        return Identity(token.owner, Role.STUDENT, "token")

    def _look_up(self, digest: str) -> Token | None:
        token = self.store.token_by_digest(digest)
        if token is not None:
            with contextlib.suppress(ElabError):  # only the "last used" time is lost
                self.store.touch_token(token.id, time.time())
        return token

    def make_token(self, owner: Identity, name: str) -> tuple[Token, str]:
        raw = TOKEN_PREFIX + secrets.token_urlsafe(32)
        token = Token("t-" + secrets.token_hex(6), owner.id, name, time.time())
        self.store.add_token(token, hashlib.sha256(raw.encode()).hexdigest())
        return token, raw

    def revoke(self, owner: Identity, token_id: str) -> None:
        self.store.revoke_token(owner.id, token_id)
        self._tokens.clear()

    def cookie(self, name: str, value: str, max_age: int | None) -> str:
        """A ``Set-Cookie`` value: HttpOnly, SameSite=Lax, Secure behind HTTPS."""
        parts = [f"{name}={value}", "Path=/", "HttpOnly", "SameSite=Lax"]
        if max_age is not None:
            parts.append(f"Max-Age={max_age}")
        if self.secure:
            parts.append("Secure")
        return "; ".join(parts)


@functools.cache
def _dummy() -> str:
    """A hash to check a password of a missing account against (the same scrypt as a
    wrong password), made on the first sign-in: scrypt's 50-70 ms are not start-up's."""
    return hash_password("not an account", b"0123456789abcdef")


class Identify:
    """Middleware: resolves the identity of every request and websocket; gives a new
    browser its anonymous identity cookie with the first response."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        auth = lab(HTTPConnection(scope)).authority
        cookies = cookies_of(scope)
        new_cookie: str | None = None
        who: Identity | None
        bearer = _bearer(scope)
        try:
            if bearer is not None:
                who = await auth.token(bearer)
            else:
                who = await auth.session(cookies.get(SESSION_COOKIE)) or auth.anonymous(
                    cookies.get(ID_COOKIE)
                )
        except ElabError as exc:
            await _refuse(scope, receive, send, exc)
            return
        if who is None:
            if scope["type"] == "http":
                who, signed = auth.new_anonymous()
                new_cookie = auth.cookie(ID_COOKIE, signed, ID_MAX_AGE)
            else:
                who = NOBODY  # a websocket without a cookie may watch only
        scope[SCOPE_KEY] = who
        if new_cookie is None:
            await self.app(scope, receive, send)
            return

        async def send_with_cookie(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                if not any(c.startswith(ID_COOKIE + "=") for c in headers.getlist("set-cookie")):
                    headers.append("set-cookie", new_cookie)
            await send(message)

        await self.app(scope, receive, send_with_cookie)


def cookies_of(scope: Scope) -> Mapping[str, str]:
    """The request's cookies by name, in one pass over the header (RFC 6265's
    ``name=value; …``; the first of a name wins). No unquoting: E-Lab's cookies are never
    quoted, and CPython's ``http.cookies`` unquoting is quadratic in backslashes
    (CVE-2024-7592: one 120 KB header held the event loop for 35 s)."""
    jar: dict[str, str] = {}
    for k, v in scope["headers"]:
        if k != b"cookie":
            continue
        for pair in v.decode("latin-1").split(";"):
            name, eq, value = pair.partition("=")
            name = name.strip()
            if eq and name and name not in jar:
                jar[name] = value.strip()
    return jar


def _bearer(scope: Scope) -> str | None:
    for k, v in scope["headers"]:
        if k == b"authorization":
            kind, _, value = v.decode("latin-1").partition(" ")
            if kind.lower() == "bearer" and value.strip():
                return str(value.strip())
            return ""  # some other scheme: refused as an unknown token
    return None


async def _refuse(scope: Scope, receive: Receive, send: Send, exc: ElabError) -> None:
    if scope["type"] == "websocket":
        await send({"type": "websocket.close", "code": 1008})  # before accept: HTTP 403
        return
    response = error_response(exc)
    response.headers["www-authenticate"] = 'Bearer realm="elab"'
    await response(scope, receive, send)


def session_cookie_value(auth: Authority, value: str | None) -> str:
    """The ``Set-Cookie`` for a sign-in (``value``) or sign-out (``None``)."""
    if value is None:
        return auth.cookie(SESSION_COOKIE, "", 0)
    return auth.cookie(SESSION_COOKIE, value, None)


def me_fields(who: Identity, auth: Authority) -> dict[str, Any]:
    return {
        "id": who.id or None,
        "name": who.name if who.id else "nobody",
        "role": who.role.value,
        "via": who.via,
        "account": who.id[len(INSTRUCTOR) :] if who.instructor else None,
        "sign_in": bool(auth.instructors),
    }
