"""The seed's numbers, reproduced with stated tolerances (scripts/seed_reproduction.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from scripts import seed_reproduction as sr

DOC = Path(__file__).resolve().parents[2] / "docs" / "seed-reproduction.md"


@pytest.fixture(scope="module")
def checks(seed_facts: dict[str, Any]) -> list[sr.Check]:
    return sr.all_checks(seed_facts)


def test_every_seed_number_is_reproduced_within_its_tolerance(checks: list[sr.Check]) -> None:
    failed = [
        f"{c.section}: {c.quantity} — error {c.error:.3g} > {c.tol:g} ({c.measure})"
        for c in checks
        if not c.ok
    ]
    assert not failed, "\n".join(failed)
    assert len(checks) >= 30


def _cells(text: str) -> list[list[str]]:
    """Table rows without the error column (its last digits depend on the BLAS build)."""
    rows = [line.split(" | ") for line in text.splitlines() if line.startswith("| ")]
    return [r[:4] + r[5:] for r in rows]


def test_the_document_is_current(checks: list[sr.Check]) -> None:
    assert _cells(DOC.read_text(encoding="utf-8")) == _cells(sr.render(checks)), (
        "docs/seed-reproduction.md is stale: run `make docs`"
    )
