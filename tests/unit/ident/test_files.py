"""Identification data from files: E-Lab's downloads, plain tables, and bad files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from elab.errors import InvalidInput
from elab.ident.files import read_csv, read_table

DRYER = Path(__file__).resolve().parents[2] / "reference" / "ident" / "dryer.dat"
ELAB_CSV = """# run: r-1
# plant: flexible_link
# sample time: 0.001 s
# units: t [s], r [rad], u [V], theta [rad], alpha [rad]
t,r,u,theta,alpha
0.0,0.5,10.0,0.0,0.0
0.001,0.5,9.5,0.0003,-0.0003
0.002,0.5,9.0,0.0012,-0.0012
"""


def test_elab_csv_gives_names_units_and_sample_time() -> None:
    t = read_table(ELAB_CSV.encode(), "csv")
    assert t.names == ("t", "r", "u", "theta", "alpha")
    assert t.units == ("s", "rad", "V", "rad", "rad")
    assert t.Ts == 0.001
    z = t.dataset(["u"], ["theta", "alpha"])
    assert (z.N, z.nu, z.ny, z.output_units) == (3, 1, 2, ("rad", "rad"))
    assert_allclose(z.u[:, 0], [10.0, 9.5, 9.0])


def test_elab_json_download_and_a_plain_json_table() -> None:
    doc = {
        "header": {"run": "r-1"},
        "Ts": 0.08,
        "k0": 0,
        "channels": [{"name": "u", "unit": "V"}, {"name": "y", "unit": "V"}],
        "t": [0, 0.08, 0.16],
        "data": {"u": [1, 2, 3], "y": [4, 5, 6]},
    }
    t = read_table(json.dumps(doc).encode(), "json")
    assert (t.names, t.units, t.Ts) == (("t", "u", "y"), ("s", "V", "V"), 0.08)
    plain = read_table(b'{"Ts": 0.5, "u": [1, 2, 3], "y": [1, 4, 9]}', "json")
    assert plain.dataset(["u"], ["y"]).Ts == 0.5


def test_a_whitespace_table_like_daisy_dryer_needs_a_sample_time() -> None:
    raw = DRYER.read_bytes()
    t = read_table(raw, "csv")
    assert t.names == ("c1", "c2") and t.data.shape == (1000, 2) and t.Ts is None
    with pytest.raises(InvalidInput, match="sample time") as err:
        t.dataset(["c1"], ["c2"])
    assert err.value.field == "Ts"
    z = t.dataset(["c1"], ["c2"], Ts=0.08)
    assert_allclose(np.unique(z.u), [3.41, 6.41])


def test_the_sample_time_comes_from_an_even_t_column() -> None:
    t = read_table(b"t,u,y\n0,1,2\n0.5,1,3\n1.0,2,3\n", "csv")
    assert t.Ts == 0.5
    uneven = read_table(b"t,u,y\n0,1,2\n0.5,1,3\n1.2,2,3\n", "csv")
    assert uneven.Ts is None


@pytest.mark.parametrize(
    "raw, fmt, field, message",
    [
        (b"", "csv", "data", "no rows"),
        (b"u,y\n1,2\n", "csv", "data", "1 rows"),
        (b"u,y\n1,2\n3\n", "csv", "data row 2", "1 values"),
        (b"u,y\n1,2\n3,abc\n", "csv", "data row 2", "3,abc"),
        (b"u,u\n1,2\n3,4\n", "csv", "columns", "distinct"),
        (b"\xff\xfe", "csv", "data", "UTF-8"),
        (b"[1, 2]", "json", "data", "JSON object"),
        (b"{nope", "json", "data", "invalid JSON"),
        (b'{"u": [1, 2], "y": [1]}', "json", "data", "equal lengths"),
        (b'{"u": [1, "a"], "y": [1, 2]}', "json", "data.u", "numbers"),
        (b'{"Ts": -1, "u": [1, 2], "y": [1, 2]}', "json", "Ts", "[1e-09, 1e+09]"),
        (b"u,y\n1,2\n3,4\n", "xlsx", "format", "csv or json"),
    ],
)
def test_bad_files_name_what_is_wrong(raw: bytes, fmt: str, field: str, message: str) -> None:
    with pytest.raises(InvalidInput) as err:
        read_table(raw, fmt)
    assert err.value.field == field
    assert message in str(err.value)


def test_unknown_columns_and_nan_are_refused() -> None:
    t = read_table(b"u,y\n1,2\n3,4\n", "csv")
    with pytest.raises(InvalidInput, match="one of the columns: u, y"):
        t.dataset(["volts"], ["y"], Ts=1.0)
    with pytest.raises(InvalidInput, match="data row 2: got '3,nan'; allowed: finite"):
        read_table(b"u,y\n1,2\n3,nan\n", "csv")
    with pytest.raises(InvalidInput, match=r"data\.y: .*finite"):
        read_table(b'{"Ts": 1, "u": [1, 2], "y": [1, 1e999]}', "json")


def test_semicolon_and_decimal_comma_files_are_read() -> None:
    """Issue 15: a spreadsheet's CSV in a decimal-comma locale (semicolons, or tabs,
    between columns; 1,5 for 1.5) is read; a comma-separated file with decimal commas,
    which cannot be told apart, is explained instead of "got '4 values'"."""
    from elab.ident.files import read_csv

    for text in (
        "t;u;y\n0,0;1,5;2,25\n0,1;1,6;-2,5e-1\n",
        "t\tu\ty\n0,0\t1,5\t2,25\n0,1\t1,6\t-2,5e-1\n",
    ):
        t = read_csv(text)
        assert t.names == ("t", "u", "y")
        assert t.data.tolist() == [[0.0, 1.5, 2.25], [0.1, 1.6, -0.25]]
    assert read_csv("u;y\n1.5;2\n1.75;3\n").data.tolist() == [[1.5, 2.0], [1.75, 3.0]]
    with pytest.raises(InvalidInput, match="decimal commas, as 1,5, its columns must be separated"):
        read_csv("u,y\n1,5,2,25\n1,6,2,5\n")


def test_a_csv_over_its_row_limit_is_refused_before_it_is_parsed() -> None:
    # the limit counts samples: a header row is not one
    assert read_csv("a b\n" + "1 2\n" * 10, max_rows=10).data.shape == (10, 2)
    with pytest.raises(InvalidInput) as exc:
        read_csv("1 2\n" * 11, max_rows=10, why=" (with the data's 5)")
    assert exc.value.field == "data" and exc.value.value == "11 samples"
    assert exc.value.allowed == "at most 10 samples (with the data's 5)"
    # refused by its count: a bad row after the limit is never read
    with pytest.raises(InvalidInput, match="at most 10 samples"):
        read_csv("1 2\n" * 11 + "x y z\n", max_rows=10)
