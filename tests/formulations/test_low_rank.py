"""Pivoted Cholesky factor, the factored ε-SVR dual as a QP, and its error bound."""

from __future__ import annotations

import numpy as np
import pytest
from support.problems import diabetes, thermal_two_sensors

from svrqp.exceptions import ProblemError
from svrqp.formulations import low_rank
from svrqp.formulations.epsilon_svr import dual_objective
from svrqp.kernels import gram
from svrqp.linalg.kernel_columns import KernelColumns
from svrqp.linalg.pivoted_cholesky import pivoted_cholesky
from svrqp.solvers import solve_qp


def test_factor_trace_error_is_the_trace_of_the_residual():
    case = diabetes()
    K = gram(case.X, gamma=case.gamma)
    columns = KernelColumns(case.X, gamma=case.gamma)
    factor = pivoted_cholesky(columns, max_rank=30, tol=0.0)
    residual = K - factor.L @ factor.L.T
    assert factor.rank == 30 == columns.evaluated  # one kernel column per pivot, no more
    assert factor.trace_error == pytest.approx(np.trace(residual), rel=1e-8, abs=1e-12)
    assert np.linalg.eigvalsh(residual)[-1] <= factor.trace_error + 1e-12  # the reported bound holds
    assert len(set(factor.pivots.tolist())) == factor.rank


def test_full_factor_reproduces_the_gram_matrix_and_stops_at_the_tolerance():
    case = thermal_two_sensors()
    K = gram(case.X, gamma=case.gamma)
    full = pivoted_cholesky(KernelColumns(case.X, gamma=case.gamma), max_rank=len(case.y), tol=1e-12)
    np.testing.assert_allclose(full.L @ full.L.T, K, atol=1e-10)
    coarse = pivoted_cholesky(KernelColumns(case.X, gamma=case.gamma), max_rank=len(case.y), tol=1e-3)
    assert coarse.relative_trace_error <= 1e-3 and coarse.rank < full.rank


def test_factored_qp_with_an_exact_factor_has_the_exact_optimum():
    case = thermal_two_sensors()
    K = gram(case.X, gamma=case.gamma)
    factor = pivoted_cholesky(KernelColumns(case.X, gamma=case.gamma), max_rank=len(case.y), tol=1e-14)
    problem = low_rank.dual_low_rank(factor.L, case.y, case.C, case.epsilon)
    beta = low_rank.beta_from_solution(len(case.y), solve_qp(problem, "clarabel").x)
    # Reference: the dense split dual of the same data solved by an independent backend (OSQP).
    from svrqp.formulations.epsilon_svr import beta_from_solution, dual_split

    dense = beta_from_solution("split", len(case.y), solve_qp(dual_split(K, case.y, case.C, case.epsilon), "osqp").x)
    assert dual_objective(K, case.y, beta, case.epsilon) == pytest.approx(
        dual_objective(K, case.y, dense, case.epsilon), rel=1e-7)


def test_objective_error_bound_holds_for_a_truncated_factor():
    case = diabetes()
    K = gram(case.X, gamma=case.gamma)
    factor = pivoted_cholesky(KernelColumns(case.X, gamma=case.gamma), max_rank=10, tol=0.0)
    LLt = factor.L @ factor.L.T
    bound = low_rank.objective_error_bound(factor, len(case.y), case.C)
    rng = np.random.default_rng(11)
    for _ in range(5):
        beta = rng.uniform(-case.C, case.C, len(case.y))
        gap = abs(dual_objective(K, case.y, beta, case.epsilon) - dual_objective(LLt, case.y, beta, case.epsilon))
        assert gap <= bound


def test_bad_arguments_are_rejected():
    case = thermal_two_sensors()
    columns = KernelColumns(case.X, gamma=case.gamma)
    with pytest.raises(ProblemError, match="max_rank"):
        pivoted_cholesky(columns, max_rank=0)
    with pytest.raises(ProblemError, match="rows"):
        low_rank.dual_low_rank(np.ones((3, 2)), case.y, case.C, case.epsilon)


def test_pivot_expansion_is_the_factored_model_and_the_exact_one_at_full_rank():
    """Σ_j c_j k(x_j, x) equals L Lᵀ β on the training points (any rank) and K β at full rank."""
    case = diabetes()
    rng = np.random.default_rng(5)
    beta = rng.uniform(-case.C, case.C, len(case.y))
    truncated = pivoted_cholesky(KernelColumns(case.X, gamma=case.gamma), max_rank=15, tol=0.0)
    c = low_rank.pivot_coefficients(truncated, beta)
    pivot_kernel = gram(case.X, case.X[truncated.pivots], gamma=case.gamma)  # independent of L
    np.testing.assert_allclose(pivot_kernel @ c, truncated.L @ (truncated.L.T @ beta), rtol=1e-8, atol=1e-8)
    full = pivoted_cholesky(KernelColumns(case.X, gamma=case.gamma), max_rank=len(case.y), tol=1e-14)
    c_full = low_rank.pivot_coefficients(full, beta)
    K = gram(case.X, gamma=case.gamma)
    np.testing.assert_allclose(gram(case.X, case.X[full.pivots], gamma=case.gamma) @ c_full, K @ beta,
                               atol=1e-6 * np.abs(K @ beta).max())
    with pytest.raises(ProblemError, match="beta"):
        low_rank.pivot_coefficients(truncated, beta[:-1])


def test_give_up_stops_early_only_when_the_tolerance_is_out_of_reach():
    """Friedman #1 (10 independent features, a slowly decaying RBF spectrum) cannot reach 3e-5 within
    n/8 columns: with give_up the factorisation stops at the first check instead of filling n/8.
    The smooth warm-up set reaches it: give_up changes nothing there."""
    from svrqp.bench import cases as bench

    X, _ = bench.friedman1(1000, 10, seed=0)
    columns = KernelColumns(X, gamma=bench.resolve_gamma("scale", X))
    full = pivoted_cholesky(columns, max_rank=125, tol=3e-5)
    early = pivoted_cholesky(columns, max_rank=125, tol=3e-5, give_up=True)
    assert full.rank == 125 and full.relative_trace_error > 3e-5
    assert early.rank < full.rank and early.relative_trace_error > 3e-5
    X, _ = bench.thermal(1000, 10, seed=0)
    columns = KernelColumns(X, gamma=bench.resolve_gamma("scale", X))
    reached = pivoted_cholesky(columns, max_rank=125, tol=3e-5, give_up=True)
    assert reached.relative_trace_error <= 3e-5
    np.testing.assert_array_equal(reached.pivots, pivoted_cholesky(columns, max_rank=125, tol=3e-5).pivots)


def test_factor_without_the_column_cache_is_the_same_factor():
    X = diabetes().X
    cached, uncached = KernelColumns(X, gamma=2.0), KernelColumns(X, gamma=2.0)
    with_cache = pivoted_cholesky(cached, max_rank=40, tol=1e-10)
    without = pivoted_cholesky(uncached, max_rank=40, tol=1e-10, cache=False)
    np.testing.assert_array_equal(without.L, with_cache.L)
    np.testing.assert_array_equal(without.pivots, with_cache.pivots)
    assert cached.evaluated == with_cache.rank and uncached.evaluated == 0
    # the uncached columns are the Gram matrix's own
    np.testing.assert_allclose(uncached.uncached(without.pivots), gram(X, gamma=2.0)[:, without.pivots],
                               rtol=1e-12, atol=1e-14)
