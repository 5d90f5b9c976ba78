"""The browser app's built assets (``/assets/*``).

Their names carry a hash of their content (Vite), so a browser may keep each for a year
without asking again. Each text asset also exists as ``name.gz``, compressed once by the
build (``frontend/scripts/precompress.mjs``): a browser that takes gzip gets those bytes
as they are, where the gzip middleware would compress the 1.1 MB plotting bundle again at
every page load (about 0.1 s of the web process's CPU each, at level 9).
"""

from __future__ import annotations

import os
from mimetypes import guess_type

import anyio.to_thread
from starlette.datastructures import Headers
from starlette.responses import FileResponse, Response
from starlette.staticfiles import NotModifiedResponse, StaticFiles
from starlette.types import Scope

from elab.api.http import accepts_gzip

#: the file's name changes with its content: never stale
IMMUTABLE = "public, max-age=31536000, immutable"


class Assets(StaticFiles):
    """``StaticFiles`` for hashed names, serving the build's ``.gz`` where it can."""

    async def get_response(self, path: str, scope: Scope) -> Response:
        request_headers = Headers(scope=scope)
        if accepts_gzip(request_headers.get("accept-encoding", "")) and not path.endswith(".gz"):
            full, stat = await anyio.to_thread.run_sync(self.lookup_path, path + ".gz")
            if stat is not None and os.path.isfile(full):
                media_type = guess_type(path)[0] or "application/octet-stream"
                response = FileResponse(
                    full,
                    stat_result=stat,
                    media_type=media_type,
                    headers={
                        "content-encoding": "gzip",
                        "vary": "Accept-Encoding",
                        "cache-control": IMMUTABLE,
                    },
                )
                if self.is_not_modified(response.headers, request_headers):
                    return NotModifiedResponse(response.headers)
                return response
        plain = await super().get_response(path, scope)
        if plain.status_code in (200, 304):
            plain.headers["cache-control"] = IMMUTABLE
        return plain
