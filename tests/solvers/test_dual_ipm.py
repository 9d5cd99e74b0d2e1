"""svrqp's interior point and crossover against libsvm, an independent KKT check, and its own variants."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.svm import SVR
from support.problems import SVR_CASES, SVRCase, thermal_two_sensors

from svrqp import datasets
from svrqp.bench import cases as bench
from svrqp.exceptions import ProblemError
from svrqp.formulations import epsilon_svr
from svrqp.formulations.epsilon_svr import dual_objective
from svrqp.kernels import gram
from svrqp.linalg.kernel_columns import KernelColumns
from svrqp.linalg.pivoted_cholesky import pivoted_cholesky
from svrqp.solvers import dual_ipm, solve_qp
from svrqp.solvers.dual_ipm.crossover import DenseColumns, _bordered_solve, _KernelAccess


def rbf(gamma: float) -> dict:
    """The kernel parameters of an RBF kernel of width ``gamma``."""
    return {"kernel": "rbf", "gamma": gamma, "degree": 3, "coef0": 0.0}


def warm_up_few_support() -> SVRCase:
    """600 samples of the benchmark's S0-like warm-up set (10 temperatures): smooth, so most points
    lie inside the tube and the support vectors are a small fraction — the working-set path's case."""
    X, y = bench.thermal(600, 10, seed=0)
    return SVRCase("warm_up_few_support", X, y, C=10.0, epsilon=0.1, gamma=bench.resolve_gamma("scale", X),
                   why="few support vectors, low numerical rank")


def libsvm_beta(case) -> tuple[np.ndarray, float]:
    """scikit-learn's SVR(tol=1e-8) on the case: the outside reference."""
    model = SVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, tol=1e-8).fit(case.X, case.y)
    beta = np.zeros(len(case.y))
    beta[model.support_] = model.dual_coef_[0]
    return beta, float(model.intercept_[0])


def assert_exact_kkt(K, y, beta, b, C, epsilon):
    """Every ε-SVR optimality condition to rounding (1e-9 relative), checked from first principles."""
    slack = 1e-9 * (1.0 + np.abs(y).max())
    assert abs(beta.sum()) <= 1e-9 * C * len(y)
    assert np.all(np.abs(beta) <= C)
    r = y - K @ beta - b
    zero, upper, lower = beta == 0, beta == C, beta == -C
    free = ~zero & ~upper & ~lower
    assert np.all(np.abs(r[zero]) <= epsilon + slack)
    assert np.allclose(r[free], epsilon * np.sign(beta[free]), atol=slack)
    assert np.all(r[upper] >= epsilon - slack) and np.all(r[lower] <= -epsilon + slack)


def assert_matches_libsvm(case, K, beta, b):
    """Objective within 1e-6 relative, predictions within 1e-5·std(y) of libsvm (DESIGN §3)."""
    reference, reference_b = libsvm_beta(case)
    ours = dual_objective(K, case.y, beta, case.epsilon)
    theirs = dual_objective(K, case.y, reference, case.epsilon)
    assert ours <= theirs + 1e-6 * abs(theirs)
    assert abs(ours - theirs) <= 1e-6 * abs(theirs)
    difference = (K @ beta + b) - (K @ reference + reference_b)
    assert np.max(np.abs(difference)) <= 1e-5 * case.y.std()


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
def test_solve_exact_matches_libsvm_and_satisfies_kkt(case_factory):
    case = case_factory()
    K = gram(case.X, gamma=case.gamma)
    fit = dual_ipm.solve_exact(K, case.y, case.C, case.epsilon)
    assert fit.ipm.converged and fit.crossover.exact
    assert_exact_kkt(K, case.y, fit.beta, fit.intercept, case.C, case.epsilon)
    assert_matches_libsvm(case, K, fit.beta, fit.intercept)


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
def test_solve_exact_from_data_matches_the_dense_path(case_factory):
    case = case_factory()
    K = gram(case.X, gamma=case.gamma)
    fit = dual_ipm.solve_exact_from_data(case.X, case.y, case.C, case.epsilon, rbf(case.gamma),
                                         settings=dual_ipm.ExactSettings(factor_tol=1e-6, max_rank=len(case.y)))
    assert fit.crossover.exact
    assert_exact_kkt(K, case.y, fit.beta, fit.intercept, case.C, case.epsilon)
    assert_matches_libsvm(case, K, fit.beta, fit.intercept)


def test_low_rank_path_forms_no_gram_and_falls_back_when_the_factor_is_poor():
    case = warm_up_few_support()
    low_rank = dual_ipm.solve_exact_from_data(case.X, case.y, case.C, case.epsilon, rbf(case.gamma),
                                              settings=dual_ipm.ExactSettings(factor_tol=1e-8, max_rank=len(case.y)))
    assert low_rank.times_s["gram_s"] == 0.0
    fallback = dual_ipm.solve_exact_from_data(case.X, case.y, case.C, case.epsilon, rbf(case.gamma),
                                              settings=dual_ipm.ExactSettings(factor_tol=1e-14, max_rank=3))
    assert fallback.times_s["gram_s"] > 0.0
    np.testing.assert_allclose(low_rank.beta, fallback.beta, atol=1e-9 * case.C)


def test_factored_interior_point_with_a_full_factor_equals_the_dense_one():
    case = thermal_two_sensors()
    K = gram(case.X, gamma=case.gamma)
    factor = pivoted_cholesky(KernelColumns(case.X, gamma=case.gamma), max_rank=len(case.y), tol=0.0)
    dense = dual_ipm.interior_point(dual_ipm.DenseKernel(K), case.y, case.C, case.epsilon)
    factored = dual_ipm.interior_point(dual_ipm.FactoredKernel(factor.L), case.y, case.C, case.epsilon)
    assert dense.converged and factored.converged
    objective = [dual_objective(K, case.y, fit.beta, case.epsilon) for fit in (dense, factored)]
    assert objective[1] == pytest.approx(objective[0], rel=1e-7)


def test_crossover_repairs_a_perturbed_start_and_reports_when_it_cannot():
    case = thermal_two_sensors()
    K = gram(case.X, gamma=case.gamma)
    exact = dual_ipm.solve_exact(K, case.y, case.C, case.epsilon)
    # Move some free coefficients to zero and some zeros off zero: wrong states to start from.
    start = exact.beta.copy()
    free = np.flatnonzero((np.abs(start) > 0) & (np.abs(start) < case.C))
    zero = np.flatnonzero(start == 0)
    start[free[:2]] = 0.0
    start[zero[:2]] = 0.3 * case.C
    repaired = dual_ipm.crossover(lambda idx: K[:, idx], case.y, case.C, case.epsilon, start)
    assert repaired.exact and repaired.steps > 1
    np.testing.assert_allclose(repaired.beta, exact.beta, atol=1e-9 * case.C)
    np.testing.assert_allclose(repaired.Kbeta, K @ repaired.beta, rtol=1e-12, atol=1e-12 * case.C)
    stopped = dual_ipm.crossover(lambda idx: K[:, idx], case.y, case.C, case.epsilon, start,
                                 settings=dual_ipm.CrossoverSettings(max_steps=1))
    assert not stopped.exact


def test_interior_point_reports_an_iteration_limit():
    case = thermal_two_sensors()
    fit = dual_ipm.interior_point(dual_ipm.DenseKernel(gram(case.X, gamma=case.gamma)), case.y, case.C,
                                  case.epsilon, max_iter=2)
    assert not fit.converged and fit.iterations == 2


@pytest.mark.parametrize("C, epsilon", [(0.0, 0.1), (np.inf, 0.1), (1.0, -0.1)])
def test_invalid_parameters_are_rejected(C, epsilon):
    case = thermal_two_sensors()
    with pytest.raises(ProblemError):
        dual_ipm.interior_point(dual_ipm.DenseKernel(gram(case.X, gamma=case.gamma)), case.y, C, epsilon)


@pytest.mark.parametrize("factor_tol", [1e-3, 1e-5])
def test_a_coarse_factor_still_gives_the_exact_optimum(factor_tol):
    """The factor only guides the search: a rough one gives a longer crossover, never another answer."""
    case = warm_up_few_support()
    K = gram(case.X, gamma=case.gamma)
    fit = dual_ipm.solve_exact_from_data(case.X, case.y, case.C, case.epsilon, rbf(case.gamma),
                                         settings=dual_ipm.ExactSettings(factor_tol=factor_tol, max_rank=len(case.y)))
    assert fit.crossover.exact and fit.times_s["gram_s"] == 0.0
    assert_exact_kkt(K, case.y, fit.beta, fit.intercept, case.C, case.epsilon)
    assert_matches_libsvm(case, K, fit.beta, fit.intercept)


def test_crossover_never_calls_an_unbalanced_all_bound_guess_exact():
    """With no free coefficient the free-set solve cannot restore 1ᵀβ = 0: such states are no optimum.

    Two unrelated points (K = I) with the same target, both guessed at +C: the midpoint bias puts
    both residuals exactly on the tube edge, so no KKT condition flags them, yet 1ᵀβ = 2C. The
    integer C also checks that an int C does not overflow the int8 states.
    """
    K, y, C = np.eye(2), np.array([10.0, 10.0]), 1
    for fast_steps, max_steps in ((10, 0), (8, 200)):
        result = dual_ipm.crossover(lambda idx: K[:, idx], y, C, 0.1, np.array([1.0, 1.0]),
                                    settings=dual_ipm.CrossoverSettings(fast_steps=fast_steps, max_steps=max_steps))
        assert not result.exact
    fit = dual_ipm.solve_exact(K, y, C, 0.1)  # from the interior point the optimum β = 0 is found
    assert fit.crossover.exact
    assert_exact_kkt(K, y, fit.beta, fit.intercept, C, 0.1)


def test_coinciding_inputs_with_different_targets_reach_the_box():
    """Two copies of one input with targets 1 and 0 (K = [[1, 1], [1, 1]]): any β with β₁ = −β₂ leaves
    f unchanged, so the dual objective −β₁ + 2ε|β₁| falls without bound until the box: β = (C, −C).

    Started with both copies free, the free-set system is inconsistent (both residuals cannot sit on
    the tube edge): the crossover must move along the null-space direction to the box, not call the
    least-squares point of that system an optimum.
    """
    K, y, C, epsilon = np.ones((2, 2)), np.array([1.0, 0.0]), 10.0, 0.1
    result = dual_ipm.crossover(lambda idx: K[:, idx], y, C, epsilon, np.array([0.3, -0.3]))
    assert result.exact
    np.testing.assert_allclose(result.beta, [C, -C])
    assert_exact_kkt(K, y, result.beta, result.intercept, C, epsilon)


def test_bordered_solve_returns_the_descent_direction_of_an_inconsistent_system():
    x, b, unbounded = _bordered_solve(np.ones((2, 2)), np.array([1.0, 0.0]), 0.0)
    assert unbounded is not None and unbounded[0] > 0
    np.testing.assert_allclose(unbounded / unbounded[0], [1.0, -1.0], atol=1e-12)
    x, b, unbounded = _bordered_solve(np.ones((2, 2)), np.array([0.5, 0.5]), 0.0)
    assert unbounded is None  # consistent: one of its many exact solutions
    np.testing.assert_allclose(np.ones((2, 2)) @ x + b, [0.5, 0.5], atol=1e-12)


def test_repeated_inputs_with_noisy_targets_are_solved_exactly():
    """miao2013's summer batch repeated six times with fresh noise on the target: quantised
    temperatures make coinciding inputs common in measured data (this seed once ended with free
    coefficients 1.7e-3 off their tube edge while the crossover called the result exact).

    The reference is Clarabel on the split QP, unpolished: libsvm stops 8e-6 off the tube edge on
    these data whatever its tolerance (1e-8 … 1e-12), so its predictions are 2e-5 away.
    """
    x1 = datasets.load("miao2013").query("batch == 'x1'")
    rng = np.random.default_rng(2)
    X = np.tile(x1[["T7_C", "T9_C"]].to_numpy(), (6, 1))
    X = (X - X.mean(axis=0)) / X.std(axis=0)
    y = np.tile(x1["error_um"].to_numpy(), 6)
    y = y + 0.3 * rng.standard_normal(y.size)
    y = (y - y.mean()) / y.std()
    C, epsilon, gamma = 10.0, 0.05, 0.5
    fit = dual_ipm.solve_exact_from_data(X, y, C, epsilon, rbf(gamma))
    K = gram(X, gamma=gamma)
    assert fit.crossover.exact
    assert_exact_kkt(K, y, fit.beta, fit.intercept, C, epsilon)
    solution = solve_qp(epsilon_svr.build("split", y, C, epsilon, K=K), "clarabel", tol=1e-10)
    reference = epsilon_svr.beta_from_solution("split", y.size, solution.x)
    ours, theirs = dual_objective(K, y, fit.beta, epsilon), dual_objective(K, y, reference, epsilon)
    assert ours <= theirs + 1e-9 * abs(theirs)
    difference = (K @ fit.beta + fit.intercept) - (K @ reference + solution.y[-1])
    assert np.max(np.abs(difference)) <= 1e-5 * y.std()


def test_bounded_term_is_recomputed_only_when_its_updates_outnumber_its_product():
    X = np.random.default_rng(0).normal(size=(60, 3))
    K = gram(X, gamma=0.5)
    calls = []

    class Columns(DenseColumns):
        def products(self, idx, v):
            calls.append(idx.size)
            return K[:, idx] @ v

    kernel = _KernelAccess(Columns(K), 60)
    fixed = np.zeros(60)
    fixed[:10] = 1.0
    kernel.update_bounded(fixed)  # from scratch: 10 columns
    fixed[10:14] = -1.0
    kernel.update_bounded(fixed)  # 4 changed columns: within the product's 10
    assert kernel.accurate
    np.testing.assert_allclose(kernel.update_bounded(fixed, fresh=True), K @ fixed, rtol=1e-13, atol=1e-13)
    assert calls == [10, 4]  # an accurate term is not recomputed
    fixed[20:30] = 1.0
    kernel.update_bounded(fixed)  # 14 changed columns in all: more than the 10 of the product
    assert not kernel.accurate
    np.testing.assert_allclose(kernel.update_bounded(fixed, fresh=True), K @ fixed, rtol=1e-13, atol=1e-13)
    assert calls == [10, 4, 10, 24] and kernel.accurate  # recomputed from all 24 bounded columns
