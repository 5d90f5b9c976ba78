"""The documentation inside the app (``GET /api/v1/help``, ``/help/{page}``): the user's
pages of the checkout's ``docs/`` as markdown, which the app renders at ``/help``.

Only the pages listed in :data:`PAGES` are served (not the developers' architecture and
benchmark notes, and never a path from the request). They are read from the ``docs``
folder beside the package in a checkout (``make run``) or from ``ELAB_DOCS``; a server
without them answers 404 saying where it looked.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

from starlette.requests import Request
from starlette.responses import Response

from elab.api import schemas as s
from elab.api.http import endpoint, ok
from elab.api.state import lab
from elab.errors import NotFound

#: the pages the app offers, in the order of its help index: (name, what it is for)
PAGES = (
    ("glossary", "The words of the lab, a sentence or two each"),
    ("plants", "The three plants and their models"),
    ("controllers", "Your own controller: file formats, fields, Python, the report"),
    ("identification", "Identification: methods, verdicts, the link model"),
    ("rig", "The real flexible-link rig: the queue, safety, identifying it"),
    ("access", "Who may do what: guests, instructors, tokens"),
    ("operations", "Running a lab: settings, limits, what the server reports"),
)
#: the checkout's docs folder (backend/elab/api/help.py → the repository's docs/)
CHECKOUT_DOCS = Path(__file__).resolve().parents[3] / "docs"


def _read(docs: Path, name: str) -> tuple[str, str]:
    """A page's title (its first heading) and markdown, from the folder ``docs``."""
    names = [n for n, _ in PAGES]
    if name not in names:
        raise NotFound("help page", name, names)
    path = docs / f"{name}.md"
    try:
        text = path.read_text(encoding="utf-8")
    except OSError:
        raise NotFound(
            "help page", f"{name} (not installed: no {path}; set ELAB_DOCS)", names
        ) from None
    title = next((ln[2:].strip() for ln in text.splitlines() if ln.startswith("# ")), name)
    return title, text


@endpoint("GET", "/help", response=s.HelpIndex, errors=())
async def help_index(request: Request) -> Response:
    """The documentation pages the app offers"""
    return ok(
        s.HelpIndex(pages=[s.HelpEntry(name=name, summary=summary) for name, summary in PAGES])
    )


@endpoint("GET", "/help/{page}", response=s.HelpPage, errors=(404,))
async def help_page(request: Request) -> Response:
    """One documentation page as markdown, with its title"""
    name = request.path_params["page"]
    docs = lab(request).settings.docs or CHECKOUT_DOCS
    title, text = await asyncio.to_thread(_read, docs, name)
    return ok(s.HelpPage(name=name, title=title, markdown=text))
