"""The repository's copies of the team's reference files are the same bytes."""

from __future__ import annotations

from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parents[1] / "reference"
TEAM = Path(__file__).resolve().parents[3] / "shared" / "reference"
COPIES = ["seed_facts.json", "ident/dryer.dat", "ident/README.md"]


@pytest.mark.parametrize("name", COPIES)
def test_copy_equals_the_team_reference(name: str) -> None:
    assert (HERE / name).is_file()
    if not (TEAM / name).is_file():
        pytest.skip(f"the team folder is not beside this checkout ({TEAM})")
    assert (HERE / name).read_bytes() == (TEAM / name).read_bytes()
