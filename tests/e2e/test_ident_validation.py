"""A separate validation file on the identification page, in real Chromium against a
real server: the hair-dryer data's first 500 samples estimate, its last 500 validate."""

from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import Page, expect

from elab.ident import workflow as wf
from elab.ident.files import read_table

DRYER = Path(__file__).resolve().parents[1] / "reference" / "ident" / "dryer.dat"


def test_a_validation_file_is_validated_on(page: Page, tmp_path: Path, shots: Path) -> None:
    rows = DRYER.read_text().splitlines()
    estimation, validation = tmp_path / "estimation.dat", tmp_path / "val.dat"
    estimation.write_text("\n".join(rows[:500]) + "\n")
    validation.write_text("\n".join(rows[500:]) + "\n")
    one_column = tmp_path / "one-column.dat"
    one_column.write_text("\n".join(r.split()[0] for r in rows[500:]) + "\n")

    page.goto("/plants/flexible_link/identification")
    page.get_by_text("Or identify from a data file").click()
    panel = page.get_by_test_id("ident-file")
    split, note = panel.locator("#idf-split"), panel.get_by_test_id("validation-note")
    expect(note).to_contain_text("Optional")
    panel.locator("#idf-file").set_input_files(str(estimation))
    panel.get_by_label("Validation file").set_input_files(str(one_column))
    expect(split).to_be_disabled()
    panel.locator("#idf-input-cols").fill("c1")
    panel.locator("#idf-output-cols").fill("c2")
    panel.locator("#idf-data-Ts").fill("0.08")
    panel.locator("#idf-models").fill("arx:2,2,3")
    panel.get_by_role("button", name="Identify").click()
    error = panel.get_by_test_id("ident-error")
    expect(error).to_contain_text("validation.output")  # the file has no column c2
    expect(error).to_contain_text("one of the columns: c1")

    panel.get_by_test_id("validation-file").set_input_files(str(validation))
    expect(note).to_contain_text("Validation uses the separate record val.dat")
    panel.get_by_role("button", name="Identify").click()
    rows_ = panel.get_by_test_id("ident-models").locator("tbody tr")
    expect(rows_.nth(0)).to_contain_text("arx 2 2 3", timeout=60_000)
    expect(error).to_be_empty()
    summary = panel.get_by_test_id("ident-data-summary")
    expect(summary).to_contain_text("validation: the 500 of the separate record val.dat")
    expect(summary).to_contain_text("the estimation data's means removed from both")

    def dataset(path: Path) -> wf.IdData:
        return read_table(path.read_bytes(), "csv").dataset(["c1"], ["c2"], 0.08)

    plan = wf.Plan(models=(wf.ModelRequest("arx", {"na": 2, "nb": 2, "nk": 3}),))
    direct = wf.run(dataset(estimation), plan, validation=dataset(validation)).models[0].fits
    shown = [float(td.split()[0]) for td in rows_.nth(0).locator("td").all_inner_texts()[:3]]
    want = [
        direct.validation_simulation.fit[0],
        direct.validation_simulation_x0.fit[0],
        direct.validation_one_step.fit[0],
    ]
    assert shown == pytest.approx(want, abs=0.01)  # the page shows 4 significant digits
    panel.screenshot(path=shots / "identification-validation-file.png")

    panel.get_by_test_id("validation-remove").click()  # back to the estimation share
    expect(split).to_be_enabled()
    expect(note).to_contain_text("Optional")
