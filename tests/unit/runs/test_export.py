"""Exports carry every float64 exactly (CSV, JSON, .mat) with their header, and
selections cut channels and time ranges as asked."""

from __future__ import annotations

import io
import json
import tracemalloc

import numpy as np
import pytest
import scipy.io
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from elab.errors import DimensionError, InvalidInput
from elab.plants import get_plant
from elab.runs import export
from elab.runs.export import (
    PART,
    Recording,
    Table,
    iter_csv,
    iter_json,
    iter_mat,
    select,
    table_from_samples,
    to_csv,
    to_json,
    to_mat,
)
from elab.sim.result import Samples
from elab.store import ParamChange

CHANNELS = (("r", "rad"), ("u", "V"), ("theta", "rad"), ("x_theta_dot", "rad/s"))
HEADER = {
    "plant": "flexible_link (Flexible link)",
    "controller": "StateFeedback(K=[1 2 3 4])",
    "signal": "Square(amplitude=0.523599, period=4)",
    "run id": "r-3f2a9c1b",
    "status": "finished",
}
CHANGES = (
    ParamChange(1300, {"controller": {"K": [1.5, 2.0, 3.0, 4.0]}}, 1.7e9),
    ParamChange(1450, {"signal": {"amplitude": 0.25}}, 1.7e9 + 0.15),
)


def make_table(n: int = 500, k0: int = 1234) -> Table:
    rng = np.random.default_rng(5)
    data = rng.standard_normal((n, len(CHANNELS))) * 10.0 ** rng.integers(-300, 300, (n, 4))
    if n >= 4:  # values whose decimal forms are the hardest to carry exactly
        data[:4, 0] = [1 / 3, 0.1, 5e-324, -1.7976931348623157e308]
    return Table(HEADER, 1e-3, k0, CHANNELS, data, CHANGES)


def parse_csv(text: str) -> tuple[list[str], list[str], np.ndarray]:
    lines = text.splitlines()
    comments = [line for line in lines if line.startswith("#")]
    names = lines[len(comments)].split(",")
    body = "\n".join(lines[len(comments) + 1 :])
    data = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2).reshape(-1, len(names))
    return comments, names, data


# -- CSV -------------------------------------------------------------------------
def test_csv_round_trip_is_exact() -> None:
    table = make_table()
    _, names, got = parse_csv(to_csv(table))
    assert names == ["t", "r", "u", "theta", "x_theta_dot"]
    # t = (k0 + i)·Ts as clean decimals (issue 15: 6.9590000000000005 read as noise)
    assert np.allclose(got[:, 0], table.t, rtol=0, atol=1e-12)
    assert all(len(repr(t)) <= 6 for t in got[:, 0].tolist())  # 1.234, 1.24, …
    assert np.array_equal(got[:, 1:], table.data)  # the data bit for bit


#: any float64 at all: subnormals, the largest, ±0, and (for CSV) NaN and ±inf
ANY_DOUBLES = hnp.arrays(
    np.float64,
    st.tuples(st.integers(1, 40), st.just(len(CHANNELS))),
    elements=st.floats(width=64, allow_nan=True, allow_infinity=True),
)


@given(ANY_DOUBLES)
def test_csv_carries_any_double_exactly(data: np.ndarray) -> None:
    _, _, got = parse_csv(to_csv(Table({}, 0.01, 0, CHANNELS, data)))
    assert np.array_equal(got[:, 1:], data, equal_nan=True)
    number = ~np.isnan(data)
    assert np.array_equal(np.signbit(got[:, 1:][number]), np.signbit(data[number]))  # -0.0


@given(ANY_DOUBLES)
def test_json_carries_any_finite_double_exactly_and_nan_as_null(data: np.ndarray) -> None:
    data[np.isinf(data)] = 0.0  # (refused: test_json_refuses_infinite_values)
    doc = json.loads(to_json(Table({}, 0.01, 0, CHANNELS, data)))
    got = np.array([[np.nan if v is None else v for v in doc["data"][n]] for n, _ in CHANNELS])
    assert np.array_equal(got.T, data, equal_nan=True)
    number = ~np.isnan(data)
    assert np.array_equal(np.signbit(got.T[number]), np.signbit(data[number]))  # -0.0 too


def test_csv_writes_unmeasured_and_infinite_samples_as_python_does() -> None:
    data = np.ones((6, 4))
    data[1, 2] = np.nan  # a sample a rig dropped
    data[4, 3] = -np.inf  # (a diverging run with saturation off)
    rows = to_csv(Table({}, 0.5, 0, CHANNELS, data)).splitlines()[-6:]
    assert rows[1] == "0.5,1.0,1.0,nan,1.0" and rows[4] == "2.0,1.0,1.0,1.0,-inf"


def test_csv_header_names_the_run_its_changes_and_units() -> None:
    comments, _, _ = parse_csv(to_csv(make_table()))
    assert comments == [
        "# plant: flexible_link (Flexible link)",
        "# controller: StateFeedback(K=[1 2 3 4])",
        "# signal: Square(amplitude=0.523599, period=4)",
        "# run id: r-3f2a9c1b",
        "# status: finished",
        "# sample time: 0.001 s",
        '# parameter changes: k=1300, t=1.3 s: {"controller": {"K": [1.5, 2.0, 3.0, 4.0]}}',
        '# parameter changes: k=1450, t=1.45 s: {"signal": {"amplitude": 0.25}}',
        "# units: t [s], r [rad], u [V], theta [rad], x_theta_dot [rad/s]",
    ]


def test_csv_header_lines_stay_single_lines() -> None:
    table = Table({"note": "two\nlines"}, 0.01, 0, CHANNELS, np.zeros((2, 4)))
    assert to_csv(table).splitlines()[0] == "# note: two lines"


def test_every_format_comes_in_parts_that_join_to_the_whole_reading_part_by_part() -> None:
    table = make_table(n=1000)
    reads: list[tuple[int, int]] = []

    def read(i0: int, i1: int) -> np.ndarray:
        reads.append((i0, i1))
        return table.data[i0:i1]

    rec = Recording(HEADER, 1e-3, table.k0, 1000, CHANNELS, read, CHANGES)
    parts = list(iter_csv(rec, rows=128))
    assert len(parts) == 1 + 8 and b"".join(parts).decode() == to_csv(table)
    assert max(i1 - i0 for i0, i1 in reads) == 128  # never more than a part at once
    reads.clear()
    assert b"".join(iter_json(rec, rows=300)) == to_json(table)
    assert max(i1 - i0 for i0, i1 in reads) == 300
    reads.clear()
    mat = b"".join(iter_mat(rec, rows=300))
    assert max(i1 - i0 for i0, i1 in reads) == 300
    got = scipy.io.loadmat(io.BytesIO(mat))
    assert np.array_equal(got["theta"][:, 0], table.data[:, 2])
    assert json.loads(to_json(table))["data"]["u"] == table.data[:, 1].tolist()


def test_csv_of_samples_keeps_the_cli_header() -> None:
    plant = get_plant("flexible_link")
    rng = np.random.default_rng(6)
    n = 50
    samples = Samples(
        plant,
        1e-3,
        0,
        rng.standard_normal(n),
        rng.standard_normal(n),
        rng.standard_normal((n, plant.ny)),
        rng.standard_normal((n, plant.nx)),
    )
    text = to_csv(samples, {"plant": "flexible_link", "generator": "elab simulate"})
    comments, names, got = parse_csv(text)
    assert comments[:3] == [
        "# plant: flexible_link",
        "# generator: elab simulate",
        "# sample time: 0.001 s",
    ]
    assert comments[3].startswith("# units: t [s], r [rad], u [V], theta [rad]")
    assert names[:3] == ["t", "r", "u"] and len(names) == 3 + plant.ny + plant.nx
    want = np.column_stack([c for _, c in samples.channels()])
    assert np.array_equal(got[:, 1:], want[:, 1:])  # the data bit for bit; t clean decimals
    assert np.allclose(got[:, 0], want[:, 0], rtol=0, atol=1e-12)
    assert text == to_csv(
        table_from_samples(samples, {"plant": "flexible_link", "generator": "elab simulate"})
    )


def test_a_table_carries_its_own_header() -> None:
    with pytest.raises(TypeError, match="header"):
        to_csv(make_table(), HEADER)


# -- JSON ------------------------------------------------------------------------
def test_json_round_trip_is_exact() -> None:
    table = make_table()
    doc = json.loads(to_json(table))
    assert doc["header"] == HEADER and list(doc["header"]) == list(HEADER)
    assert (doc["Ts"], doc["k0"]) == (1e-3, 1234)
    assert doc["channels"] == [{"name": n, "unit": u} for n, u in CHANNELS]
    assert np.array_equal(np.array(doc["t"]), table.t)
    assert np.array_equal(np.column_stack([doc["data"][n] for n, _ in CHANNELS]), table.data)
    assert doc["param_changes"] == [
        {"k": 1300, "t": 1300 * 1e-3, "params": {"controller": {"K": [1.5, 2.0, 3.0, 4.0]}}},
        {"k": 1450, "t": 1450 * 1e-3, "params": {"signal": {"amplitude": 0.25}}},
    ]


@pytest.mark.parametrize("bad", [float("inf"), float("-inf")])
def test_json_refuses_infinite_values(bad: float) -> None:
    data = np.zeros((10, 4))
    data[7, 2] = bad
    with pytest.raises(InvalidInput, match=r"t = 0\.07 s") as err:
        to_json(Table({}, 0.01, 0, CHANNELS, data))
    assert err.value.field == "data.theta"


def test_json_writes_a_sample_nobody_measured_as_null() -> None:
    data = np.ones((10, 4))
    data[7, 2:] = np.nan  # a sample a rig dropped: its reference and voltage are known
    doc = json.loads(to_json(Table({}, 0.01, 0, CHANNELS, data)))
    assert doc["data"]["theta"][7] is None and doc["data"]["u"][7] == 1.0
    assert doc["data"]["theta"][6] == 1.0


# -- MATLAB ----------------------------------------------------------------------
def test_mat_round_trip_is_exact() -> None:
    table = make_table()
    mat = scipy.io.loadmat(io.BytesIO(to_mat(table)))
    assert np.array_equal(mat["t"], table.t[:, None])
    for j, (name, _) in enumerate(CHANNELS):
        assert mat[name].shape == (table.data.shape[0], 1)
        assert np.array_equal(mat[name][:, 0], table.data[:, j])
    assert (mat["Ts"].item(), mat["k0"].item()) == (1e-3, 1234)
    assert [str(u.item()) for u in mat["units"].ravel()] == [
        "r [rad]",
        "u [V]",
        "theta [rad]",
        "x_theta_dot [rad/s]",
    ]
    assert [row.rstrip() for row in mat["header"]] == [f"{k}: {v}" for k, v in HEADER.items()]
    assert [row.rstrip() for row in mat["param_changes"]][1] == (
        'k=1450, t=1.45 s: {"signal": {"amplitude": 0.25}}'
    )


@pytest.mark.parametrize("n", [0, 1, 3, 1000])
@pytest.mark.parametrize("name", ["abcd", "abcde", "x_theta_dot_filtered"])
def test_a_streamed_mat_file_is_what_scipy_writes_byte_for_byte(name: str, n: int) -> None:
    """The columns written by hand (heads, then values part by part through a file) and
    the variables scipy writes, in one file equal to a ``savemat`` of them all, past its
    128-byte header (which holds the time of writing). Names of 4 and 5 bytes: packed in
    their tag or not."""
    rng = np.random.default_rng(n)
    data = rng.standard_normal((n, 2))
    table = Table({"plant": "p"}, 0.01, 7, ((name, "V"), ("u", "V")), data, CHANGES[:1])
    rec = export._recording(table)
    out = io.BytesIO()
    expected = {
        "Ts": np.float64(0.01),
        "k0": np.float64(7),
        "t": (7 + np.arange(n))[:, None] * 0.01,  # n×1 (a 1-D empty one would be 0×0)
        name: data[:, :1],
        "u": data[:, 1:],
        "channels": np.array([name, "u"], dtype=object),
        "units": np.array([f"{name} [V]", "u [V]"], dtype=object),
        "header": np.array(["plant: p"]),
        "param_changes": np.array([export._change_line(rec, CHANGES[0])]),
    }
    scipy.io.savemat(out, expected, format="5", oned_as="column")
    got = b"".join(iter_mat(rec, rows=max(1, n // 3)))
    assert got[128:] == out.getvalue()[128:]


def test_mat_names_are_matlab_identifiers() -> None:
    chans = (("1x", "m"), ("a-b", "V"), ("t", "s"), ("end", "1"), ("a_b", "V"), ("β", "rad"))
    table = Table({"plant": "θ-rig"}, 0.5, 0, chans, np.arange(12.0).reshape(2, 6))
    mat = scipy.io.loadmat(io.BytesIO(to_mat(table)))
    names = [str(c.item()) for c in mat["channels"].ravel()]
    assert names == ["c_1x", "a_b", "t_2", "c_end", "a_b_2", "c__"]
    for j, name in enumerate(names):
        assert np.array_equal(mat[name][:, 0], table.data[:, j])
    assert mat["header"][0].rstrip() == "plant: θ-rig"


# -- selection -----------------------------------------------------------------
def test_select_picks_channels_in_the_order_asked() -> None:
    table = make_table()
    got = select(table, ["theta", "r"])
    assert got.channels == (("theta", "rad"), ("r", "rad"))
    assert np.array_equal(got.read(0, got.n), table.data[:, [2, 0]])
    assert np.array_equal(got.t(), table.t)


def test_select_keeps_samples_in_the_closed_time_range() -> None:
    table = make_table()
    t = table.t
    got = select(table, None, t_from=float(t[100]), t_to=float(t[300]))
    assert got.k0 == table.k0 + 100 and got.n == 201
    assert np.array_equal(got.t(), t[100:301])
    assert np.array_equal(got.read(0, got.n), table.data[100:301])
    assert np.array_equal(got.read(50, 60), table.data[150:160])  # parts read relative to it
    # k = 1300 is at row 66 and 1450 at row 216: only the first applies up to row 150
    assert select(table, None, t_to=float(t[150])).param_changes == CHANGES[:1]
    assert select(table, None, t_from=float(t[-1]) + 1.0).n == 0


@pytest.mark.parametrize(("channels", "bad"), [(["r", "phi"], "phi"), (["u", "u"], "u"), ([], [])])
def test_select_refuses_unknown_channels(channels: list[str], bad: object) -> None:
    with pytest.raises(InvalidInput) as err:
        select(make_table(), channels)
    assert (err.value.field, err.value.value) == ("channels", bad)
    if bad == "phi":
        assert "one of: r, u, theta, x_theta_dot" in str(err.value)


@pytest.mark.parametrize(("t_from", "t_to"), [(2.0, 1.0), (float("nan"), None)])
def test_select_refuses_a_bad_time_range(t_from: float, t_to: float | None) -> None:
    with pytest.raises(InvalidInput) as err:
        select(make_table(), None, t_from, t_to)
    assert err.value.field == "t_from"


# -- tables ----------------------------------------------------------------------
def test_a_table_has_one_column_per_channel() -> None:
    with pytest.raises(DimensionError):
        Table({}, 1e-3, 0, CHANNELS, np.zeros((5, 3)))
    with pytest.raises(InvalidInput, match="unique"):
        Table({}, 1e-3, 0, (("r", "V"), ("r", "V")), np.zeros((5, 2)))


def test_an_empty_table_exports_in_every_format() -> None:
    table = make_table(n=0)
    assert to_csv(table).splitlines()[-1] == "t,r,u,theta,x_theta_dot"
    assert json.loads(to_json(table))["t"] == []
    assert scipy.io.loadmat(io.BytesIO(to_mat(table)))["t"].size == 0


# -- memory --------------------------------------------------------------------
@pytest.mark.parametrize("fmt", ["csv", "json", "mat"])
def test_a_long_download_holds_a_few_parts_in_memory_not_the_recording(fmt: str) -> None:
    """Ten parts of rows (5 MiB of doubles, about 12 MiB of text) written while the
    Python allocator's peak stays under 16 MiB, issue 28's bound whatever the length."""
    n = 10 * PART
    ramp = np.linspace(0.0, 1.0, PART * len(CHANNELS)).reshape(PART, len(CHANNELS))

    def read(i0: int, i1: int) -> np.ndarray:
        return ramp[: i1 - i0] + i0  # made when read, as the store does

    rec = Recording(HEADER, 1e-3, 0, n, CHANNELS, read, CHANGES)
    write = {"csv": iter_csv, "json": iter_json, "mat": iter_mat}[fmt]
    tracemalloc.start()
    try:
        sent = sum(len(part) for part in write(rec))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert sent > n * len(CHANNELS) * 8  # (more than the recording's doubles went out)
    assert peak < 16 * 2**20, f"{fmt}: {peak / 2**20:.1f} MiB at the peak"
