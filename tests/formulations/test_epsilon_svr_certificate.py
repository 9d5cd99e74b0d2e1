"""The one ε-SVR certificate: states, rebuilt multipliers and per-point violations (S0 eq. 6)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.svm import SVR
from support.epsilon_svr_reference import full_beta
from support.problems import SVR_CASES

from svrqp.formulations import epsilon_svr
from svrqp.formulations.epsilon_svr_certificate import (
    box_multipliers,
    dual_qp_point,
    kkt_violation,
    multipliers,
    states,
)
from svrqp.kernels import gram


def test_states_sort_by_the_tolerance():
    C = 2.0
    beta = np.array([-C, -C * (1 - 1e-7), -0.5, -1e-9, 0.0, 1e-9, 0.5, C * (1 - 1e-7), C])
    np.testing.assert_array_equal(states(beta, C, 1e-6), [-2, -2, -1, 0, 0, 0, 1, 2, 2])
    np.testing.assert_array_equal(states(beta, C, 0.0), [-2, -1, -1, -1, 0, 1, 1, 1, 2])  # exactly 0 or ±C
    np.testing.assert_array_equal(states(beta, C, 1e-6, zero_tol=1.0), [-2, -2, 0, 0, 0, 0, 0, 2, 2])


def test_violation_of_each_condition_in_units_of_y():
    epsilon = 0.1
    r = np.array([0.05, -0.3, 0.1, 0.25, -0.1, -0.02, 0.3, -0.02])
    state = np.array([0, 0, 1, 1, -1, -1, 2, -2], dtype=np.int8)
    # zero: |r| - ε; free: |r - ε s|; at +C: ε - r; at -C: r + ε (≤ 0 where the condition holds)
    expected = [-0.05, 0.2, 0.0, 0.15, 0.0, 0.08, -0.2, 0.08]
    np.testing.assert_allclose(kkt_violation(r, state, epsilon), expected, atol=1e-15)


@pytest.mark.parametrize("formulation", ["split", "stacked"])
def test_rebuilt_multipliers_leave_only_the_projected_part_in_stationarity(formulation):
    """For any (β, b) the box multipliers have the signs their bounds allow (complementarity is
    exact); what the projection removed, and only that, is the stationarity residual."""
    case = SVR_CASES[1]()
    K = gram(case.X, gamma=case.gamma)
    rng = np.random.default_rng(7)
    beta, b = rng.uniform(-case.C, case.C, case.y.size), 0.3
    beta[:3] = [case.C, -case.C, 0.0]
    problem = epsilon_svr.build(formulation, case.y, case.C, case.epsilon, K=K)
    point = multipliers(beta, b, K @ beta, case.y, case.epsilon)
    x, y_eq, z_box = dual_qp_point(formulation, point, case.C)
    residuals = problem.kkt_residuals(x, y_eq, None, z_box)
    assert residuals["complementarity"] == 0.0
    removed = np.max(np.abs(point.z_box - z_box[-point.z_box.size:]))
    assert removed > 0.0
    assert residuals["dual"] == pytest.approx(removed, rel=1e-12)
    np.testing.assert_allclose(epsilon_svr.beta_from_solution(formulation, case.y.size, x), beta, rtol=0, atol=0)


def test_box_multipliers_keep_the_signs_each_bound_allows():
    x = np.array([0.0, 0.0, 0.5, 2.0, 2.0])
    z = np.array([-1.0, 1.0, 3.0, -1.0, 1.0])
    np.testing.assert_array_equal(box_multipliers(x, z, 2.0), [-1.0, 0.0, 0.0, 0.0, 1.0])


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
def test_violations_vanish_at_libsvm_optimum_and_see_a_shifted_bias(case_factory):
    case = case_factory()
    reference = SVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, tol=1e-10).fit(case.X, case.y)
    beta = full_beta(reference, case.y.size)
    b = float(reference.intercept_[0])
    K = gram(case.X, gamma=case.gamma)
    state = states(beta, case.C, 1e-6)
    point = multipliers(beta, b, K @ beta, case.y, case.epsilon)
    assert np.max(kkt_violation(point.residual, state, case.epsilon)) <= 1e-5 * case.y.std()
    shifted = multipliers(beta, b + 0.1 * case.y.std(), K @ beta, case.y, case.epsilon)
    free = np.abs(state) == 1
    np.testing.assert_allclose(kkt_violation(shifted.residual, state, case.epsilon)[free], 0.1 * case.y.std(),
                               rtol=1e-3)


@pytest.mark.parametrize("formulation", ["split", "stacked"])
def test_stated_dual_is_the_built_qp_at_any_point(formulation):
    """The closed form equals the generic residuals of the built QP, off the optimum too."""
    from svrqp.formulations.epsilon_svr_residuals import stated_dual

    rng = np.random.default_rng(3)
    n, C, epsilon = 7, 2.5, 0.3
    y = rng.normal(size=n)
    K = gram(rng.normal(size=(n, 2)), gamma=0.7)
    built = epsilon_svr.build(formulation, y, C, epsilon, K=K)
    for beta in (rng.uniform(-C, C, n), rng.uniform(-2 * C, 2 * C, n)):  # inside and outside the box
        stated = stated_dual(formulation, y, C, epsilon, beta, 0.2, K @ beta, 1.0)
        x, y_eq, z, z_box = stated.point
        expected = built.kkt_residuals(x, y_eq, z, z_box)
        for key, value in expected.items():
            assert stated.residuals[key] == pytest.approx(value, rel=1e-12, abs=1e-14), key
        assert stated.objective == pytest.approx(built.objective(x), rel=1e-12)
        assert stated.name == built.name
        assert stated.residuals["primal_rel"] > 0 and stated.residuals["gap_rel"] > 1e-3


def test_stated_dual_names_a_formulation_it_does_not_know():
    from svrqp.exceptions import ProblemError
    from svrqp.formulations.epsilon_svr_residuals import stated_dual

    with pytest.raises(ProblemError, match="formulation"):
        stated_dual("primal", np.zeros(2), 1.0, 0.1, np.zeros(2), 0.0, np.zeros(2), 1.0)


def test_the_certificates_spread_is_numpys_std_to_the_bit():
    from svrqp.formulations.epsilon_svr_certificate import std

    rng = np.random.default_rng(0)
    for n in (1, 2, 7, 50, 1000, 12345):
        for y in (rng.normal(size=n) * 1e3 + 5.0, np.full(n, 0.1), rng.integers(0, 3, n).astype(float)):
            assert std(y) == float(np.std(y))
    assert np.isnan(std(np.zeros(0)))
