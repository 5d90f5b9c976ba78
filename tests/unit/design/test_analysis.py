"""elab.design.analysis: eigenvalues, stability verdicts, rank tests, transfer functions."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_less

from elab.design import (
    analyze,
    controllability,
    observability,
    stability,
    transfer_functions,
)
from elab.errors import DimensionError, InvalidInput
from elab.plants import PLANTS

FLEX = PLANTS["flexible_link"]
PENDULUM = PLANTS["double_pendulum"]
BELT = PLANTS["belt_conveyor"]


def _complex(values: list[str]) -> np.ndarray:
    return np.array([complex(v) for v in values])


# --- eigenvalues and stability ------------------------------------------------------------


def test_flexible_link_eigenvalues_match_recomputed_and_seed(seed_facts: dict[str, Any]) -> None:
    eig = stability(FLEX.A).eigenvalues
    facts = seed_facts["flexible_link"]
    # seed_facts "eigenvalues_recomputed" (python-control 0.10.2), printed to 5 decimals.
    assert_allclose(eig, _complex(facts["eigenvalues_recomputed"]), rtol=0, atol=1e-5)
    # Seed §4.1.2 prints 4 decimals, but its -22.1942 and -7.4138 differ from the eigenvalues
    # of its own printed A by 3.4e-4 and 6.8e-5 (the seed computed with unrounded A entries):
    # agreement to 5e-4, not to the printed half-unit 5e-5.
    assert_allclose(eig, _complex(facts["eigenvalues_seed"]), rtol=0, atol=5e-4)


def test_pendulum_eigenvalues_match_seed_to_printed_precision(seed_facts: dict[str, Any]) -> None:
    eig = stability(PENDULUM.A).eigenvalues
    expected = _complex(seed_facts["rotary_double_pendulum"]["eigenvalues_seed"])
    # Seed §4.2.2 prints 4 decimals; the model reproduces each to half a unit of the last digit.
    assert_allclose(np.sort_complex(eig), np.sort_complex(expected), rtol=0, atol=5e-5)


def test_belt_conveyor_eigenvalues_are_those_of_its_model() -> None:
    # belt_conveyor docstring: motor pole -1/tau_m = -5, load poles s^2 + 20 s + 125 = 0, x = ∫v.
    assert_allclose(stability(BELT.A).eigenvalues, [0, -5, -10 + 5j, -10 - 5j], atol=1e-12)


@pytest.mark.parametrize(
    ("plant_id", "verdict", "phrase"),
    [
        ("flexible_link", "marginally stable", "eigenvalue 0 on the imaginary axis (simple)"),
        ("belt_conveyor", "marginally stable", "eigenvalue 0 on the imaginary axis (simple)"),
        ("double_pendulum", "unstable", "eigenvalue 5.222 in the right half-plane"),
    ],
)
def test_plant_stability_verdicts(plant_id: str, verdict: str, phrase: str) -> None:
    result = stability(PLANTS[plant_id].A)
    assert result.verdict == verdict
    assert phrase in result.reason


def test_eigenvalues_are_sorted_by_real_part_then_imaginary_part() -> None:
    eig = stability(FLEX.A).eigenvalues
    assert list(eig.real) == sorted(eig.real, reverse=True)
    assert eig[1].imag > 0 > eig[2].imag


@pytest.mark.parametrize(
    ("A", "verdict", "phrase"),
    [
        ([[-1, 0], [0, -2]], "asymptotically stable", "largest real part -1"),
        ([[0, 1], [-4, 0]], "marginally stable", "±2j on the imaginary axis (simple)"),
        ([[0, 0], [0, 0]], "marginally stable", "multiplicity 2"),
        ([[0, 1], [0, 0]], "unstable", "Jordan block"),
        ([[1, -5], [5, 1]], "unstable", "1±5j in the right half-plane"),
        (
            [[0, 1, 1, 0], [-4, 0, 0, 1], [0, 0, 0, 1], [0, 0, -4, 0]],
            "unstable",
            "Jordan block",
        ),
    ],
)
def test_stability_verdicts_of_textbook_matrices(A: Any, verdict: str, phrase: str) -> None:
    result = stability(A)
    assert result.verdict == verdict
    assert phrase in result.reason


def test_stability_rejects_a_non_square_matrix() -> None:
    with pytest.raises(DimensionError, match=r"^A: "):
        stability([[0, 1, 2], [3, 4, 5]])


# --- controllability and observability ----------------------------------------------------


@pytest.mark.parametrize("plant", PLANTS.values(), ids=list(PLANTS))
def test_every_plant_is_controllable_and_observable(plant: Any) -> None:
    ctrb, obsv = controllability(plant.A, plant.B), observability(plant.A, plant.C)
    assert ctrb.full and ctrb.rank == plant.nx
    assert obsv.full and obsv.rank == plant.nx
    for report in (ctrb, obsv):
        # numpy's matrix_rank uses the same default tolerance max(shape)·eps·σ_max.
        assert report.rank == np.linalg.matrix_rank(report.matrix)
        sigma = report.singular_values
        assert_allclose(report.condition_number, sigma[0] / sigma[-1], rtol=1e-12)


def test_flexible_link_controllability_matrix_is_badly_scaled_but_full_rank() -> None:
    report = controllability(FLEX.A, FLEX.B)
    # The seed calls the plant controllable (seed_facts "controllable": true); the Kalman
    # matrix spans 5 orders of magnitude, far from the rank tolerance.
    assert report.condition_number > 1e5
    assert report.singular_values[-1] > 1e6 * report.tol


def test_uncontrollable_pair_is_reported_rank_deficient() -> None:
    report = controllability([[-1, 0], [0, -2]], [1, 0])
    assert report.rank == 1 and not report.full
    assert report.condition_number == np.inf


# --- transfer functions --------------------------------------------------------------------


def test_flexible_link_transfer_functions(seed_facts: dict[str, Any]) -> None:
    theta, alpha = transfer_functions(FLEX.A, FLEX.B, FLEX.C, FLEX.D, ["theta", "alpha"], "u")
    b, k_s, k_d = 65.113, 921.77 - 566.46, 37.022  # A, B entries of seed §4.1.1
    # Exact from the model: θ/u = b (s² + k_s) / (s (s³ + k_d s² + 921.77 s + k_d k_s)).
    assert_allclose(theta.num, [b, 0, b * k_s], rtol=1e-12)
    assert_allclose(theta.den, [1, k_d, 921.77, k_d * k_s, 0], rtol=1e-12)
    assert theta.num[1] == 0.0 and theta.den[-1] == 0.0  # round-off cleaned to exact zeros
    assert_allclose(alpha.num, [-b, 0, 0], rtol=1e-12)
    assert np.all(alpha.num[1:] == 0.0)
    facts = seed_facts["flexible_link"]
    # seed_facts lists 23140.3 and 13150.2, which are the seed's 4-digit prints (2.314e+04,
    # 1.315e+04, eq. 4.1) padded; the printed A gives 23135.3 and 13154.3, i.e. 2.2e-4 and
    # 3.1e-4 relative. Assert to the seed's printed precision, half a unit of the 4th digit.
    assert_allclose(theta.num, facts["tf_theta_over_u"]["num"], rtol=0, atol=5.0)
    assert_allclose(theta.den, facts["tf_theta_over_u"]["den"], rtol=0, atol=5.0)
    assert_allclose(alpha.num, facts["tf_alpha_over_u"]["num"], rtol=1e-12)


def test_pendulum_transfer_functions_match_seed_eq_4_8() -> None:
    tfs = transfer_functions(
        PENDULUM.A, PENDULUM.B, PENDULUM.C, PENDULUM.D, ["alpha", "beta1", "beta2"], "u"
    )
    # Seed eq. 4.8 denominator; each printed coefficient must be within one unit of its last
    # digit (the seed's 4.252 is 4.2528 from its printed A: rounding differs by 0.8 unit).
    printed = np.array([1, 0.6895, 12.65, 4.252, -1145, -336.3, 0])
    unit = np.array([0, 1e-4, 1e-2, 1e-3, 1, 0.1, 0]) + 1e-12
    for tf in tfs:
        assert_array_less(np.abs(tf.den - printed), unit)
    # Seed eq. 4.8 numerators. The seed's model had more digits of B than eq. 4.7 prints
    # (its β1 numerator leads with 0.01391 where eq. 4.7 has B = 0.0139), so agreement is
    # 2 % per coefficient; the seed also omits the -1.8e-4 s terms of β1 and β2.
    seed_num = {
        "alpha": [0.0302, 0.01051, 0.3998, -0.001291, -31.28],
        "beta1": [0.01391, 0.002917, 0.549, 0, 0],
        "beta2": [-0.02091, -0.002894, 0.549, 0, 0],
    }
    for tf, B_i in zip(tfs, PENDULUM.B[3:, 0], strict=True):
        assert_allclose(tf.num, seed_num[tf.output], rtol=2e-2, atol=2e-4)
        # Defining property: the leading coefficient is the Markov parameter C A B = B_i
        # (to the round-off of ss2tf, ~eps times the largest coefficient 1145).
        assert_allclose(tf.num[0], B_i, rtol=1e-9)


def test_transfer_functions_evaluate_to_the_state_space_model() -> None:
    rng = np.random.default_rng(7)
    A = rng.standard_normal((5, 5)) - 3 * np.eye(5)
    B, C, D = rng.standard_normal((5, 1)), rng.standard_normal((2, 5)), rng.standard_normal((2, 1))
    tfs = transfer_functions(A, B, C, D, ["y0", "y1"], "u")
    for s in (0.3j, 2.0 + 1.0j, 10j):
        G = C @ np.linalg.solve(s * np.eye(5) - A, B) + D  # definition C (sI - A)^-1 B + D
        values = [np.polyval(tf.num, s) / np.polyval(tf.den, s) for tf in tfs]
        assert_allclose(values, G[:, 0], rtol=1e-10)


def test_transfer_function_text_and_latex() -> None:
    theta = analyze(FLEX).transfer_functions[0]
    assert theta.text() == "(65.11 s^2 + 2.314e+04) / (s^4 + 37.02 s^3 + 921.8 s^2 + 1.315e+04 s)"
    assert theta.latex() == (
        "\\frac{65.11 s^{2} + 2.314 \\times 10^{4}}"
        "{s^{4} + 37.02 s^{3} + 921.8 s^{2} + 1.315 \\times 10^{4} s}"
    )
    alpha = analyze(FLEX).transfer_functions[1]
    assert alpha.text(precision=3).startswith("(-65.1 s^2) / (")


def test_transfer_functions_check_names_and_single_input() -> None:
    with pytest.raises(DimensionError, match=r"^output_names: "):
        transfer_functions(FLEX.A, FLEX.B, FLEX.C, FLEX.D, ["theta"], "u")
    with pytest.raises(DimensionError, match=r"^B: "):
        transfer_functions(FLEX.A, np.hstack([FLEX.B, FLEX.B]), FLEX.C, FLEX.D, ["a", "b"], "u")
    with pytest.raises(InvalidInput, match=r"^A: "):
        transfer_functions([[np.nan]], [1], [1], [0], ["y"], "u")


@pytest.mark.parametrize("plant", PLANTS.values(), ids=list(PLANTS))
def test_analyze_names_one_transfer_function_per_output(plant: Any) -> None:
    result = analyze(plant)
    assert [tf.output for tf in result.transfer_functions] == [o.name for o in plant.outputs]
    assert all(tf.input == plant.inputs[0].name for tf in result.transfer_functions)
    assert all(tf.den[0] == 1.0 and tf.den.size == plant.nx + 1 for tf in result.transfer_functions)
    with pytest.raises(ValueError, match="read-only"):
        result.stability.eigenvalues[0] = 1.0
