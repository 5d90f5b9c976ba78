"""The help inside the app (elab/api/helpdocs.py): the listed pages of docs/ as markdown,
nothing else (no path from the request reaches the file system), and a clear 404."""

from __future__ import annotations

from pathlib import Path

import pytest

from elab.api.helpdocs import PAGES
from tests.api.server import Server

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_every_listed_page_is_the_docs_file(server: Server) -> None:
    with server.client() as c:
        index = c.get("/help").json()["pages"]
        assert [p["name"] for p in index] == [n for n, _ in PAGES]
        assert index[0]["name"] == "glossary"
        for entry in index:
            page = c.get(f"/help/{entry['name']}").json()
            text = (DOCS / f"{entry['name']}.md").read_text(encoding="utf-8")
            assert page["markdown"] == text
            assert page["title"] == text.splitlines()[0].removeprefix("# ")


@pytest.mark.parametrize(
    "name", ["architecture", "benchmarks", "glossary.md", "GLOSSARY", "x" * 300, "%2e%2e"]
)
def test_pages_not_listed_are_404_naming_those_that_are(server: Server, name: str) -> None:
    with server.client() as c:
        r = c.get(f"/help/{name}")
    assert r.status_code == 404, r.text
    assert "unknown help page" in r.json()["error"]["message"]
    assert "glossary" in r.json()["error"]["message"]


def test_a_path_out_of_the_docs_reaches_no_file(server: Server) -> None:
    with server.client() as c:
        for path in ("/help/..%2Fpyproject", "/help/../../pyproject.toml", "/help/%2Fetc%2Fpasswd"):
            r = c.get(path)
            assert r.status_code == 404, (path, r.text)
            assert "[project]" not in r.text and "root:" not in r.text


def test_the_app_answers_help_addresses_with_itself(server: Server) -> None:
    with server.client() as c:
        for path in ("/help", "/help/glossary"):
            r = c.get(server.url + path, headers={"accept": "text/html"})
            assert r.status_code == 200 and "<html" in r.text.lower(), path
