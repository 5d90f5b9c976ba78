"""The seed's numbers, reproduced with stated tolerances (scripts/seed_reproduction.py)."""

from __future__ import annotations

import re
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


def test_the_document_is_current(checks: list[sr.Check]) -> None:
    stale = sr.stale(DOC.read_text(encoding="utf-8"), checks)
    assert not stale, "docs/seed-reproduction.md is stale (run `make docs`):\n" + "\n".join(stale)


def test_round_off_is_printed_as_a_bound_not_as_a_fact(checks: list[sr.Check]) -> None:
    """Issue 23: the document held a Riccati residual of 1.7e-14, 6.5e-14 on another CPU."""
    text = DOC.read_text(encoding="utf-8")
    assert "< 1e-12" in text
    assert not [n for n in re.findall(r"\d\.?\d*e-(\d+)", text) if int(n) > 12]


@pytest.mark.parametrize(
    ("before", "after"),
    [
        ("-22.1945", "-22.1955"),  # an eigenvalue moved by 1e-3 (tolerance 1e-5)
        ("[20, -93.5614, 3.36206, 0.962235]", "[20.01, -93.5614, 3.36206, 0.962235]"),
        ("rise 6.43 s", "rise 6.53 s"),  # an exact row
        ("| 5.4e-06 |", "| 2.4e-05 |"),  # an error moved by more than the tolerance
    ],
)
def test_a_number_moved_beyond_its_tolerance_makes_the_document_stale(
    checks: list[sr.Check], before: str, after: str
) -> None:
    text = DOC.read_text(encoding="utf-8")
    assert before in text
    assert sr.stale(text.replace(before, after, 1), checks)


def test_a_number_moved_within_its_tolerance_does_not(checks: list[sr.Check]) -> None:
    """The rise time's tolerance is 0.5 s: another CPU's last digit is no reason to fail."""
    text = DOC.read_text(encoding="utf-8")
    assert not sr.stale(text.replace("0.343 s", "0.344 s", 1), checks)
