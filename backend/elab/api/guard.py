"""Safe on a network (docs/access.md): checks every request before anything else runs.

- ``Host`` must be one of the server's names (``ELAB_HOSTS``): a page on another
  site cannot reach a lab bound to 127.0.0.1 by rebinding its DNS name to it.
- A request that may change something (any method but GET, HEAD, OPTIONS) from a
  browser must come from the lab's own pages: a cross-site ``Sec-Fetch-Site`` or an
  ``Origin`` other than the server's own (or one in ``ELAB_ORIGINS``) gets 403.
  Browsers send these headers and pages cannot forge them; scripts send neither.
  With SameSite cookies this is the CSRF defence (no token to carry around).
- A websocket upgrade with a foreign ``Origin`` is refused (HTTP 403).
- An API body must be ``application/json``: a ``text/plain`` body, which any page
  can send without asking, gets 415. The one exception is a controller file sent as
  ``multipart/form-data`` to ``POST /api/v1/controllers`` (what ``curl -F`` and a form
  send): a page on another site could post that too, which the ``Origin`` and
  ``Sec-Fetch-Site`` checks above refuse, and it only adds a controller to the sender's
  own list.
- Every response has the security headers: a content security policy with no inline
  script, no framing by other sites, ``nosniff``, a same-origin referrer policy.
"""

from __future__ import annotations

import re

from starlette.datastructures import Headers, MutableHeaders
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
JSON = "application/json"
FORM = "multipart/form-data"
FORM_PATHS = frozenset({"/api/v1/controllers"})  # where a file may come as a form
CSP = (
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data: blob:; font-src 'self' data:; connect-src 'self'; "
    "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'"
)
SECURITY_HEADERS = (
    ("content-security-policy", CSP),
    ("x-content-type-options", "nosniff"),
    ("referrer-policy", "same-origin"),
    ("x-frame-options", "DENY"),
    ("cross-origin-opener-policy", "same-origin"),
)


class Guard:
    def __init__(self, app: ASGIApp, hosts: tuple[str, ...], origins: tuple[str, ...]) -> None:
        self.app = app
        self.any_host = "*" in hosts
        self.hosts = frozenset(h.lower().strip("[]") for h in hosts)
        self.origins = frozenset(origins)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        kind = scope["type"]
        if kind not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        problem = self._check(scope, headers)
        if problem is not None:
            status, code, message = problem
            if kind == "websocket":
                await send({"type": "websocket.close", "code": 1008})  # before accept: 403
                return
            body: dict[str, object] = {
                "error": {"code": code, "message": message, "field": None, "errors": []}
            }
            await _secured(JSONResponse(body, status_code=status), scope, receive, send)
            return
        if kind == "websocket":
            await self.app(scope, receive, send)
            return

        async def send_secured(message: Message) -> None:
            if message["type"] == "http.response.start":
                h = MutableHeaders(scope=message)
                for k, v in SECURITY_HEADERS:
                    h.setdefault(k, v)
            await send(message)

        await self.app(scope, receive, send_secured)

    def _check(self, scope: Scope, headers: Headers) -> tuple[int, str, str] | None:
        host = headers.get("host", "")
        if not self.any_host and _hostname(host) not in self.hosts:
            return (
                400,
                "invalid",
                f"Host {host[:60]!r} is not a name of this server (ELAB_HOSTS: "
                f"{', '.join(sorted(self.hosts))})",
            )
        method = scope.get("method", "GET")
        if scope["type"] == "websocket" or method not in SAFE_METHODS:
            site = headers.get("sec-fetch-site")
            origin = headers.get("origin")
            if origin is not None and not self._own(origin, host, scope.get("scheme", "http")):
                return (
                    403,
                    "forbidden",
                    f"a page from {origin[:80]} may not use this lab (only its own pages "
                    "and ELAB_ORIGINS may)",
                )
            if site is not None and site not in ("same-origin", "none") and origin is None:
                return 403, "forbidden", f"a {site} request may not change anything here"
        if scope["type"] == "http" and method not in SAFE_METHODS:
            ctype = headers.get("content-type")
            has_body = headers.get("content-length", "0") not in ("0", "") or (
                "transfer-encoding" in headers
            )
            media = None if ctype is None else ctype.split(";")[0].strip().lower()
            form = method == "POST" and scope["path"] in FORM_PATHS
            if (ctype is not None or has_body) and media != JSON and not (form and media == FORM):
                also = f" or {FORM} (a file)" if form else ""
                return (
                    415,
                    "unsupported_media_type",
                    f"content-type: got {ctype!r}; allowed: {JSON} (a JSON body){also}",
                )
        return None

    def _own(self, origin: str, host: str, scheme: str) -> bool:
        """``origin`` is exactly the server's own (the scheme, host and port the request
        came to: ``https`` behind a TLS proxy in ``ELAB_TRUSTED_PROXIES``, which says so)
        or a configured one (``ELAB_ORIGINS``)."""
        if origin.lower() in self.origins:
            return True
        ours = {"ws": "http", "wss": "https"}.get(scheme, scheme)
        return origin.lower() == f"{ours}://{host.strip().lower()}"


_HOST = re.compile(r"(\[[0-9a-f:.]+\]|[a-z0-9]([a-z0-9.-]*[a-z0-9])?)(:[0-9]{1,5})?")


def _hostname(host: str) -> str | None:
    """``Host`` without its port (``[::1]:8000`` → ``::1``), or ``None`` if it is not a
    host name or address with an optional port (``127.0.0.1:8000@evil.example`` is not)."""
    host = host.strip().lower()
    m = _HOST.fullmatch(host)
    if m is None:
        return None
    name = m.group(1)
    return name[1:-1] if name.startswith("[") else name


async def _secured(response: JSONResponse, scope: Scope, receive: Receive, send: Send) -> None:
    for k, v in SECURITY_HEADERS:
        response.headers[k] = v
    await response(scope, receive, send)
