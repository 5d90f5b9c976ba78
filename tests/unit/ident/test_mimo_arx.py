"""ARX with several inputs and outputs: one least-squares problem per output, as GNU
Octave's ``arx`` (control package; its nk = MATLAB's nk − 1). Data: the DaISy CD player
arm (2 inputs, 2 outputs; tests/reference/ident/cd_player_arm.md), samples 1…1024 to
estimate and 1025…2048 to validate, each detrended by its own mean."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.signal
from numpy.testing import assert_allclose

from elab.api.identjson import ident_json
from elab.errors import InvalidInput
from elab.ident import IdData, iddata
from elab.ident import workflow as wf
from elab.ident.polynomial import arx, arxstruc, struc

CD = Path(__file__).resolve().parents[2] / "reference" / "ident" / "cd_player_arm.dat"
OCTAVE = shutil.which("octave")
# (na, nb, nk), MATLAB's nk: scalars, one na per output and an nb per output and input.
# Octave takes only one nk, and starts each output's regression nk − 1 samples after
# max(na_i, max_j nb_ij) where E-Lab (as MATLAB) starts at max(na_i, max_j nb_ij + nk − 1):
# the same sample for these structures.
STRUCTURES: list[tuple[Any, Any, int]] = [
    (2, 2, 1),
    (4, 4, 1),
    ([2, 3], [[2, 1], [3, 2]], 2),
    (1, [[3, 3], [2, 2]], 3),
]

SCRIPT = """pkg load control
d = load('{data}'); u = d(1:1024, 1:2); y = d(1:1024, 3:4);
ze = iddata(y - mean(y), u - mean(u), 1);
{calls}"""
CALL = """sys = arx(ze, 'na', {na}, 'nb', {nb}, 'nk', {nk});
[num, den] = filtdata(sys);  % in powers of q⁻¹; inputs: u1, u2, then the noises
for i = 1:2
  printf('%.17g ', den{{i, 1}}); printf('\\n');
  for j = 1:2; printf('%.17g ', num{{i, j}}); printf('\\n'); end
end
"""


@pytest.fixture(scope="module")
def cd_record() -> IdData:
    raw = np.loadtxt(CD)
    return iddata(raw[:, 2:], raw[:, :2], 1.0)  # DaISy gives no sample time


@pytest.fixture(scope="module")
def cd_player(cd_record: IdData) -> tuple[IdData, IdData]:
    return cd_record[:1024].detrend(), cd_record[1024:].detrend()


def _octave(value: Any) -> str:
    return "[" + "; ".join(" ".join(str(v) for v in row) for row in np.atleast_2d(value)) + "]"


def _call(na: Any, nb: Any, nk: int) -> str:
    if np.ndim(na) or np.ndim(nb):  # Octave: both scalars, or na 2 × 1 and nb 2 × 2
        na, nb = np.broadcast_to(np.reshape(na, (-1, 1)), (2, 1)), np.broadcast_to(nb, (2, 2))
    return CALL.format(na=_octave(na), nb=_octave(nb), nk=nk - 1)


@pytest.fixture(scope="module")
def octave_arx(tmp_path_factory: pytest.TempPathFactory) -> list[list[np.ndarray]]:
    """Per structure: A_1, B_11, B_12, A_2, B_21, B_22 from one Octave process."""
    if OCTAVE is None:
        pytest.skip("GNU Octave is not installed (make test installs octave and octave-control)")
    calls = "".join(_call(*s) for s in STRUCTURES)
    script = tmp_path_factory.mktemp("octave") / "mimo_arx.m"
    script.write_text(SCRIPT.format(data=CD, calls=calls))
    done = subprocess.run(
        [str(OCTAVE), "--no-gui", "--quiet", "--no-window-system", str(script)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = [ln for ln in done.stdout.splitlines() if ln.strip()]
    assert len(lines) == 6 * len(STRUCTURES), done.stdout + done.stderr
    vals = [np.array([float(v) for v in ln.split()]) for ln in lines]
    return [vals[6 * s : 6 * s + 6] for s in range(len(STRUCTURES))]


@pytest.mark.parametrize("s", range(len(STRUCTURES)))
def test_mimo_arx_equals_octave(
    cd_player: tuple[IdData, IdData], octave_arx: list[list[np.ndarray]], s: int
) -> None:
    m = arx(cd_player[0], *STRUCTURES[s])
    p = m.parameters
    ours = [p.A[0], *p.B[0], p.A[1], *p.B[1]]
    for mine, theirs in zip(ours, octave_arx[s], strict=True):
        # Octave solves by QR then SVD, E-Lab by LAPACK's gelsd: equal to round-off
        assert_allclose(mine, theirs, rtol=1e-9, atol=1e-12)


def test_each_output_is_its_own_least_squares_problem(cd_player: tuple[IdData, IdData]) -> None:
    """Output i's polynomials are the least-squares solution over the regressors written
    out here sample by sample, with a delay and a count of lags per channel."""
    ze, _ = cd_player
    na, nb, nk = [2, 1], [[2, 1], [1, 3]], [[1, 2], [0, 1]]
    m = arx(ze, na, nb, nk)
    y, u = ze.y, ze.u
    for i in range(2):
        start = max(na[i], *(nb[i][j] + nk[i][j] - 1 for j in range(2)))
        rows = [
            [-y[t - k, i] for k in range(1, na[i] + 1)]
            + [u[t - nk[i][j] - k, j] for j in range(2) for k in range(nb[i][j])]
            for t in range(start, ze.N)
        ]
        theta = np.linalg.lstsq(np.array(rows), y[start:, i], rcond=None)[0]
        p = m.parameters
        assert_allclose(p.A[i], [1, *theta[: na[i]]], rtol=1e-10)
        b = theta[na[i] :]
        assert_allclose(p.B[i][0], [0] * nk[i][0] + [*b[: nb[i][0]]], rtol=1e-10)
        assert_allclose(p.B[i][1], [0] * nk[i][1] + [*b[nb[i][0] :]], rtol=1e-10)
        assert p.samples[i] == ze.N - start


def test_a_decoupled_output_equals_the_single_input_arx(cd_player: tuple[IdData, IdData]) -> None:
    """nb_ij = 0 leaves input j out: each output is then the one-input ARX."""
    ze, _ = cd_player
    m = arx(ze, 2, [[2, 0], [0, 3]], 1)
    for i, (j, nb) in enumerate([(0, 2), (1, 3)]):
        siso = arx(iddata(ze.y[:, i], ze.u[:, j], ze.Ts), 2, nb, 1)
        assert_allclose(m.parameters.A[i], siso.parameters.A, rtol=1e-12)
        assert_allclose(m.parameters.B[i][j], siso.parameters.B, rtol=1e-12)
        assert m.parameters.B[i][1 - j].tolist() == [0.0]  # nk = 1 zero, no coefficient
        assert m.parameters.loss[i] == pytest.approx(siso.parameters.loss, rel=1e-12)


# a 2 × 2 ARX system: A_1 = 1 − 1.5 q⁻¹ + 0.7 q⁻², A_2 = 1 − 0.8 q⁻¹; B with delays 0…2
TRUE_A = [[1.0, -1.5, 0.7], [1.0, -0.8]]
TRUE_B = [[0.0, 1.0, 0.5], [0.0, 0.0, 0.3], [0.4], [0.0, 1.0, -0.6, 0.2]]
ORDERS = ([2, 1], [[2, 1], [1, 3]], [[1, 2], [0, 1]])


def _true_system(N: int, seed: int) -> IdData:
    u = np.random.default_rng(seed).standard_normal((N, 2))
    y = np.column_stack(
        [
            sum(scipy.signal.lfilter(TRUE_B[2 * i + j], TRUE_A[i], u[:, j]) for j in range(2))
            for i in range(2)
        ]
    )
    return iddata(y, u, 0.01)


def test_a_noise_free_two_by_two_arx_is_recovered() -> None:
    z = _true_system(400, 7)
    m = arx(z, *ORDERS)
    got_b = [b for row in m.parameters.B for b in row]
    for got, true in zip([*m.parameters.A, *got_b], TRUE_A + TRUE_B, strict=True):
        assert_allclose(got, true, atol=1e-9)
    # the state space is the same system: it simulates (D: the undelayed u1 → y2) and
    # predicts one step ahead (K) the noise-free data exactly, from rest
    assert m.nx == 2 + 3 and m.D[1, 0] == pytest.approx(0.4, abs=1e-9)
    assert_allclose(m.simulate(z.u), z.y, atol=1e-9)
    assert_allclose(m.predict(z), z.y, atol=1e-9)


def test_the_state_space_is_the_arx_predictor(cd_player: tuple[IdData, IdData]) -> None:
    """On real data the model's simulation is A⁻¹B u (lfilter per channel) and its one-step
    prediction is (1 − A) y + B u, past values before the record taken as zero."""
    ze, zv = cd_player
    m = arx(ze, *ORDERS)
    A, B = m.parameters.A, [b for row in m.parameters.B for b in row]
    u, y = zv.u, zv.y
    sim = np.column_stack(
        [sum(scipy.signal.lfilter(B[2 * i + j], A[i], u[:, j]) for j in range(2)) for i in range(2)]
    )
    one = np.column_stack(
        [
            scipy.signal.lfilter(np.r_[0.0, -np.array(A[i][1:])], [1.0], y[:, i])
            + sum(scipy.signal.lfilter(B[2 * i + j], [1.0], u[:, j]) for j in range(2))
            for i in range(2)
        ]
    )
    assert_allclose(m.simulate(u), sim, atol=1e-9 * np.abs(sim).max())
    assert_allclose(m.predict(zv), one, atol=1e-12 * np.abs(one).max())
    # Λ: each output's residual variance (Σ ε² over samples − parameters), correlated
    lam, p = m.noise_variance, m.parameters
    d = np.array([2 + 2 + 1, 1 + 1 + 3])  # na_i + Σ_j nb_ij
    assert_allclose(np.diag(lam), np.array(p.loss) / (1 - d / np.array(p.samples)), rtol=1e-12)
    assert_allclose(lam, lam.T, rtol=1e-15)
    assert np.all(np.linalg.eigvalsh(lam) > 0)


@pytest.mark.parametrize(
    ("orders", "field", "says"),
    [
        ((2, 2, 1), "data", "more than"),  # on 6 samples, below
        (([2, 2, 2], 2, 1), "na", "2 of them (one per output)"),
        ((2, [[2, 2]], 1), "nb", "a 2 × 2 matrix"),
        ((2, -1, 1), "nb", "an integer ≥ 0"),
        ((2, 2, 1.5), "nk", "an integer ≥ 0"),
        ((2, 2, [[1, 2], [1, -1]]), "nk", "2 × 2"),
        ((True, 2, 1), "na", "an integer ≥ 0"),
        ((2, [[1, 2], [3]], 1), "nb", "a 2 × 2 matrix"),  # ragged
        ((0, [[0, 0], [1, 1]], 1), "nb[0]", "na + Σ nb ≥ 1 for every output"),
    ],
)
def test_bad_orders_are_named(
    cd_player: tuple[IdData, IdData], orders: tuple[Any, Any, Any], field: str, says: str
) -> None:
    z = cd_player[0][:6] if field == "data" else cd_player[0]
    with pytest.raises(InvalidInput) as err:
        arx(z, *orders)
    assert err.value.field == field
    assert says in str(err.value)


def test_arxstruc_of_one_output_and_two_inputs_is_the_arx_validation_loss(
    cd_player: tuple[IdData, IdData],
) -> None:
    """Each row's loss is the mean squared one-step error on the validation data of the
    arx model of that structure (nb, nk for both inputs), from zero initial values."""
    ze, zv = (IdData(z.y[:, [1]], z.u, z.Ts) for z in cd_player)
    V = arxstruc(ze, zv, struc([1, 3], [1, 2], [1, 2]))
    for na, nb, nk, loss in V:
        m = arx(ze, int(na), [[int(nb)] * 2], [[int(nk)] * 2])
        e = zv.y - m.predict(zv)
        assert loss == pytest.approx(float(np.mean(e**2)), rel=1e-9)


def test_the_order_search_is_each_outputs_own(cd_player: tuple[IdData, IdData]) -> None:
    """The workflow's search gives each output the search of its own data (the wire puts
    them under ``arx_search_outputs``)."""
    ze, zv = cd_player
    ranges = (range(1, 4), range(1, 3), range(1, 3))
    plan = wf.Plan(arx_search=ranges, correlation=False, spectral=False)
    out = wf.run(ze, plan, validation=zv).analyses.arx_search
    assert [o.output for o in out] == ["y1", "y2"]
    for i, o in enumerate(out):
        one = (IdData(z.y[:, [i]], z.u, z.Ts) for z in (ze, zv))
        V = arxstruc(*one, struc(*ranges))
        assert_allclose(_by_structure(o.losses), _by_structure(V), rtol=1e-12)
        assert list(o.best) == V[np.argmin(V[:, 3]), :3].astype(int).tolist()


def _by_structure(V: np.ndarray) -> np.ndarray:
    return V[np.lexsort(V[:, :3].T)]


def test_the_workflow_fits_arx_to_two_outputs(cd_record: IdData) -> None:
    plan = wf.Plan(models=(wf.parse_model("arx:2,2,1"),), correlation=False, spectral=False)
    result = wf.run(cd_record, plan)
    (model,) = result.models
    assert model.name == "arx 2 2 1" and len(model.model.parameters.A) == 2
    f = model.fits
    for fits in (f.validation_simulation, f.validation_simulation_x0, f.validation_one_step):
        assert len(fits.fit) == 2 and all(np.isfinite(fits.fit)), fits.fit
    assert min(f.validation_one_step.fit) > 50  # 83 % and 78 %: it predicts
    assert np.shape(model.model.noise_variance) == (2, 2)
    assert json.loads(ident_json(result))["models"][0]["kind"] == "arx"  # the wire takes it


@pytest.mark.parametrize("kind", ["armax:2,2,2,1", "oe:2,2,1"])
def test_armax_and_oe_on_two_outputs_name_the_kind(cd_record: IdData, kind: str) -> None:
    plan = wf.Plan(models=(wf.parse_model(kind),), correlation=False, spectral=False)
    with pytest.raises(InvalidInput) as err:
        wf.run(cd_record, plan)
    assert err.value.field == "models[0].kind" and err.value.value == kind.split(":")[0]
    assert "one output and one input" in str(err.value)
