"""Data an identification cannot use, sent exactly as users sent it (issue 16): each gets
the clean error of what is wrong, or a result whose undefined numbers say so, from the
library, the CLI and its JSON alike; never a traceback, -inf or an order range 1 … 0."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.signal

from elab.cli import main
from elab.errors import InvalidInput
from elab.ident import IdData, iddata
from elab.ident import workflow as wf

N = 400


def system(u: np.ndarray) -> np.ndarray:
    rng = np.random.default_rng(3)
    return np.convolve(u, [0.0, 0.5, 0.3])[: u.size] + 0.01 * rng.standard_normal(u.size)


def noise(n: int = N, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).standard_normal(n)


def write(path: Path, u: np.ndarray, y: np.ndarray) -> Path:
    rows = zip(u.tolist(), y.tolist(), strict=True)
    path.write_text("u,y\n" + "".join(f"{a!r},{b!r}\n" for a, b in rows))
    return path


def cli(capsys: pytest.CaptureFixture[str], path: Path, *extra: str) -> tuple[int, str, str]:
    code = main(["identify", str(path), "--input", "u", "--output", "y", "--Ts", "0.1", *extra])
    out, err = capsys.readouterr()
    return code, out, err


def plan(*models: str, **kw: object) -> wf.Plan:
    return wf.Plan(models=tuple(wf.parse_model(m) for m in models), **kw)  # type: ignore[arg-type]


@pytest.mark.parametrize("ask", [("--model", "n4sid"), ("--search", "arx:1-4,1-4,1"), ()])
def test_an_output_that_is_all_zero_is_named(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, ask: tuple[str, ...]
) -> None:
    """Before: 'orders in 1 … 0', a LinAlgError traceback, or 'delay None samples'."""
    code, out, err = cli(capsys, write(tmp_path / "z.csv", noise(), np.zeros(N)), *ask)
    assert code == 2 and out == ""
    assert "y: got 'an output that is constant (0) over all 200 samples" in err
    assert "Traceback" not in err and "1 … 0" not in err


def test_an_input_constant_over_the_estimation_part_is_named(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """Before: ZeroDivisionError in the correlation analysis."""
    u = noise()
    u[: N // 2] = 1.0
    code, _, err = cli(capsys, write(tmp_path / "c.csv", u, system(u)), "--model", "arx:2,2,1")
    assert code == 2 and "u: got 'an input that is constant'" in err


def test_a_constant_validation_output_gives_undefined_fits_not_minus_infinity(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    u = noise()
    y = system(u)
    y[N // 2 :] = 2.0
    path = write(tmp_path / "v.csv", u, y)
    code, out, _ = cli(capsys, path, "--model", "arx:2,2,1")
    assert (
        code == 0
        and "validation fit undefined (simulation, zero initial state), undefined (one step)" in out
    )
    assert "the validation part of y is constant" in out and "inf" not in out
    code, out, _ = cli(capsys, path, "--model", "arx:2,2,1", "--json")
    data = json.loads(out)  # valid JSON: no -Infinity
    fit = data["models"][0]["fit"]
    assert fit["validation_simulation"] == [None] and fit["estimation_simulation"][0] > 90


def test_a_short_record_is_judged_by_what_was_asked(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """40 samples: before, n4sid:4 was refused for the correlation analysis's prewhitening.
    Now the order is refused for what it is, and a model that fits is fitted with the
    correlation analysis (asked for beside it) skipped and said so."""
    u = noise(40)
    path = write(tmp_path / "s.csv", u, system(u))
    code, _, err = cli(capsys, path, "--model", "n4sid:4")
    assert code == 2 and "models[0].order: got 4" in err and "prewhitening" not in err
    code, out, _ = cli(capsys, path, "--model", "arx:1,2,1", "--analyses", "correlation")
    assert code == 0 and "arx 1 2 1: validation fit" in out
    assert "note: correlation analysis skipped" in out
    code, _, err = cli(capsys, path)  # the correlation analysis was all that was asked
    assert code == 2 and "prewhitening" in err


def test_no_delay_is_said_in_words(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    u = noise()
    code, out, _ = cli(capsys, write(tmp_path / "n.csv", u, noise(seed=9)))
    assert code == 0
    assert "no delay found" in out and "None" not in out


def test_the_horizon_range_is_the_one_the_input_supports(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """Three sines are persistently exciting of order 6: horizons up to 3. Before, the
    error offered 2 … 58 (the data's bound) and refused most of it for excitation."""
    t = np.arange(700)
    u = np.sin(0.3 * t) + np.sin(1.1 * t) + np.sin(2.0 * t)
    path = write(tmp_path / "h.csv", u, system(u))
    code, _, err = cli(capsys, path, "--model", "n4sid:2,20")
    assert code == 2 and "an integer in 2 … 3 for this input" in err
    code, out, _ = cli(capsys, path, "--model", "n4sid:2")  # the default horizon adapts
    assert code == 0 and "n4sid 2: validation fit" in out
    z = IdData(system(u)[:, None], u[:, None], 0.1)
    assert wf.run(z, plan("n4sid:2")).models[0].model.parameters.horizon == 3
    with pytest.raises(InvalidInput) as e:
        wf.run(z, plan("n4sid:2,20"))
    assert e.value.field == "models[0].horizon"


def test_a_sample_time_column_filled_once_is_the_sample_time(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """As benchmark files have it: ``Ts`` given in the first row only (before: refused,
    'got 2 values; allowed: 3 values')."""
    from elab.ident.files import read_csv

    u = noise()
    y = system(u)
    lines = ["u,y,Ts"] + [
        f"{a!r},{b!r}" + (",0.05" if i == 0 else "")
        for i, (a, b) in enumerate(zip(u.tolist(), y.tolist(), strict=True))
    ]
    table = read_csv("\n".join(lines))
    assert table.names == ("u", "y") and table.Ts == 0.05 and table.data.shape == (N, 2)
    first = ["Ts,u,y", "0.05,1,2", ",3,4", ",5,6"]
    t2 = read_csv("\n".join(first))
    assert t2.names == ("u", "y") and t2.Ts == 0.05 and t2.data.tolist() == [[1, 2], [3, 4], [5, 6]]
    with pytest.raises(InvalidInput, match="2 different values"):
        read_csv("u,y,Ts\n1,2,0.05\n3,4,0.1\n5,6,")
    path = tmp_path / "ts.csv"
    path.write_text("\n".join(lines))
    code = main(["identify", str(path), "--input", "u", "--output", "y", "--model", "arx:2,2,1"])
    out, err = capsys.readouterr()
    assert code == 0 and "at Ts = 0.05 s" in out, err


def test_a_separate_validation_record_is_detrended_with_the_estimation_records_means(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """``--validation FILE``: the data file is all estimation; the validation record gets
    the estimation record's means removed, so an offset of its own shows in its fit
    instead of being taken out by its own mean (validation information leaking into the
    model's offset)."""
    u1, u2 = noise(seed=1), noise(seed=2)
    est = write(tmp_path / "e.csv", u1, system(u1))
    same = write(tmp_path / "v.csv", u2, system(u2))
    shifted = write(tmp_path / "s.csv", u2, system(u2) + 0.5)
    model = ("--model", "arx:2,2,1", "--json")
    fits = []
    for val in (same, shifted):
        code, out, err = cli(capsys, est, *model, "--validation", str(val))
        assert code == 0, err
        data = json.loads(out)
        assert data["data"]["estimation"] == N and data["data"]["N"] == 2 * N
        fits.append(data["models"][0]["fit"]["validation_simulation"][0])
    assert fits[0] > 95 and fits[1] < fits[0] - 20  # the offset is seen, not hidden
    bad = tmp_path / "b.csv"
    bad.write_text("u,q\n1,2\n3,4\n5,6\n")
    code, _, err = cli(capsys, est, "--validation", str(bad))
    assert code == 2 and "y" in err
    z1 = IdData(system(u1)[:, None], u1[:, None], 0.1, ("y",), ("u",))
    z2 = IdData(system(u2)[:, None], u2[:, None], 0.2, ("y",), ("u",))
    with pytest.raises(InvalidInput, match=r"sample time 0\.1 s") as e:
        wf.run(z1, plan("arx:2,2,1"), validation=z2)
    assert e.value.field == "validation.Ts"


def test_a_frozen_output_and_a_clipped_channel_are_said() -> None:
    """Issue 16: segments a linear model cannot describe are detected and said — an
    output stuck while the input moves, a channel clipped at its extreme — and the
    two-level input of a PRBS experiment (at its extremes by design) is not suspected."""
    from elab.ident import workflow as wf

    rng = np.random.default_rng(4)
    u = np.sign(rng.standard_normal(N))  # two levels: not "clipped"
    y = scipy.signal.lfilter([0, 0.5], [1, -0.8], u) + 0.01 * rng.standard_normal(N)
    plan = wf.Plan(models=(wf.parse_model("arx:1,1,1"),), correlation=False, spectral=False)
    assert not any("stays at" in n or "sits at" in n for n in wf.run(iddata(y, u, 0.1), plan).notes)
    frozen = y.copy()
    frozen[100:160] = frozen[100]  # 60 samples: a stuck sensor
    notes = wf.run(iddata(frozen, u, 0.1, output_names=("y",)), plan).notes
    assert any(n.startswith("y stays at") and "60 samples (t = 10 … 15.9 s)" in n for n in notes)
    smooth = scipy.signal.lfilter([0, 0.2], [1, -0.9], rng.standard_normal(N))
    clipped = np.clip(smooth, None, np.quantile(smooth, 0.97))  # the top 3 % cut off
    notes = wf.run(iddata(y, clipped, 0.1, input_names=("u",)), plan).notes
    assert any(n.startswith("u sits at its largest value") and "3.0 %" in n for n in notes)


def test_a_static_model_and_an_explicit_order_need_no_more(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """ARX [0 1 0] is a static gain (no state): it crashed the CLI with a ValueError.
    And an n4sid model of a given order does not make the workflow compute the order table
    for orders 1 … 10 that nobody asked for."""
    u = noise()
    y = 0.7 * u + 0.01 * noise(seed=1)
    code, out, err = cli(capsys, write(tmp_path / "s.csv", u, y), "--model", "arx:0,1,0")
    assert code == 0 and err == "" and "arx 0 1 0: validation fit" in out
    plan = wf.Plan(models=(wf.parse_model("n4sid:2"),), correlation=False, spectral=False)
    result = wf.run(iddata(system(u), u, 0.1), plan)
    assert result.analyses.n4sid_orders is None and result.models[0].name == "n4sid 2"
    plan = wf.Plan(models=(wf.parse_model("n4sid"),), correlation=False, spectral=False)
    assert wf.run(iddata(system(u), u, 0.1), plan).analyses.n4sid_orders  # needed there


@pytest.mark.parametrize(
    ("peak", "channel"), [(1e300, "y1"), (1e51, "y1"), (1e-300, "u1"), (5e-324, "u1")]
)
def test_a_channel_outside_the_representable_range_is_refused_by_name(
    peak: float, channel: str
) -> None:
    """Data of 1e300 overflowed every method's sums of squares (a RuntimeWarning, or inf
    in a result), and an input of 1e-300 was said to be "not persistently exciting"."""
    u, y = noise(), system(noise())
    u, y = (u, y / np.abs(y).max() * peak) if channel == "y1" else (u / np.abs(u).max() * peak, y)
    with pytest.raises(InvalidInput) as refused:
        iddata(y, u, 0.1)
    assert refused.value.field == channel
    assert "largest magnitude in [1e-50, 1e+50], or all zero" in str(refused.value)


SCALES = [2.0**165, 2.0**-165, 1e49, 1e-49, 3e17, 7e-23]


@pytest.mark.parametrize("scale", SCALES)
@pytest.mark.parametrize("model", ["n4sid", "arx:2,2,1", "oe:2,2,1"])
def test_every_unit_gives_the_same_models(model: str, scale: float) -> None:
    """The dryer's data in any unit inside the range: the same poles and fits, without a
    warning (pytest makes warnings errors), within round-off of the conditioning.
    Before, 1e-100 gave n4sid a realisation whose continuous form logm could not take
    accurately, and an input of 1e-300 was refused as not exciting."""
    from tests.unit.ident.public_sets import SETS

    ze, _ = next(s for s in SETS if s.name == "dryer").records()
    chosen = plan(model, correlation=True, spectral=True)
    base = wf.run(ze, chosen).models[0]
    scaled = wf.run(iddata(ze.y * scale, ze.u * scale, ze.Ts), chosen).models[0]
    assert scaled.name == base.name  # the same order chosen
    poles = np.sort_complex(np.linalg.eigvals(base.model.A))
    moved = np.sort_complex(np.linalg.eigvals(scaled.model.A))
    np.testing.assert_allclose(moved, poles, rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        scaled.fits.headline_fit.fit, base.fits.headline_fit.fit, rtol=0, atol=1e-7
    )
    assert (scaled.continuous is None) == (base.continuous is None)
    if base.continuous is not None and scaled.continuous is not None:
        np.testing.assert_allclose(scaled.continuous.A, base.continuous.A, rtol=1e-6, atol=1e-9)


def test_a_constant_input_of_any_size_is_constant_after_detrending() -> None:
    """2.5e45 less its rounded mean left 1e29 of round-off that the correlation analysis
    took for a signal (and divided 0 by 0)."""
    u = np.r_[np.full(N // 2, 2.5e45), 2.5e45 * noise(N // 2)]
    z = iddata(system(u / 1e45), u, 0.1).detrend()
    assert np.all(z.u[: N // 2] != 0)  # the whole record's mean: not constant
    head = iddata(system(u / 1e45)[: N // 2], u[: N // 2], 0.1).detrend()
    assert np.all(head.u == 0.0)
    with pytest.raises(InvalidInput, match="an input that is constant"):
        wf.run(iddata(system(u / 1e45), u, 0.1), plan("arx:2,2,1"))
