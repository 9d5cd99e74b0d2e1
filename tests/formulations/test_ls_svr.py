"""LS-SVR: Cholesky + Schur equals the full KKT solve; without bias it is KernelRidge(alpha=1/C)."""

import numpy as np
import pytest
import scipy.linalg
from sklearn.kernel_ridge import KernelRidge
from support.problems import SVR_CASES

from svrqp import LSSVR, ProblemError, SingularSystemError
from svrqp.formulations.ls_svr import kkt_system, solve_cholesky_schur
from svrqp.kernels import gram


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
def test_schur_equals_direct_kkt_solve(case_factory):
    case = case_factory()
    K = gram(case.X, gamma=case.gamma)
    alpha, b, solution = solve_cholesky_schur(K, case.y, case.C)
    system = kkt_system(K, case.y, case.C)
    direct = scipy.linalg.solve(system.M, system.rhs)  # LU of the full bordered matrix
    np.testing.assert_allclose(np.concatenate([[b], alpha]), direct, rtol=1e-9, atol=1e-9 * np.abs(direct).max())
    assert solution.residuals["primal_rel"] < 1e-12
    assert abs(alpha.sum()) < 1e-9 * np.abs(alpha).max()  # first KKT row: 1ᵀα = 0


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
def test_without_bias_equals_kernel_ridge(case_factory):
    case = case_factory()
    ours = LSSVR(C=case.C, gamma=case.gamma, fit_intercept=False).fit(case.X, case.y)
    ridge = KernelRidge(alpha=1.0 / case.C, kernel="rbf", gamma=case.gamma).fit(case.X, case.y)
    np.testing.assert_allclose(ours.dual_coef_[0], ridge.dual_coef_, rtol=1e-9, atol=1e-9 * np.abs(ridge.dual_coef_).max())
    np.testing.assert_allclose(ours.predict(case.X), ridge.predict(case.X), atol=1e-9 * case.y.std())


def test_lu_and_cholesky_estimators_agree_and_keep_the_system():
    case = SVR_CASES[1]()
    chol = LSSVR(C=0.5, gamma=case.gamma).fit(case.X, case.y)
    lu = LSSVR(C=0.5, gamma=case.gamma, solver="lu").fit(case.X, case.y)
    np.testing.assert_allclose(chol.predict(case.X), lu.predict(case.X), atol=1e-9 * case.y.std())
    assert chol.problem_.M.shape == (len(case.y) + 1,) * 2
    assert chol.solution_.backend == "cholesky" and lu.solution_.backend == "lu"


def test_non_psd_kernel_is_a_singular_system():
    K = np.array([[1.0, 3.0], [3.0, 1.0]])  # eigenvalues 4 and −2
    with pytest.raises(SingularSystemError, match="positive definite"):
        solve_cholesky_schur(K, np.ones(2), C=10.0)
    with pytest.raises(ProblemError, match="C"):
        solve_cholesky_schur(np.eye(2), np.ones(2), C=0.0)


def test_a_factor_that_breaks_down_numerically_is_a_singular_system_not_a_nan_bias():
    # check_finite=False lets LAPACK factor an infinite diagonal; the Schur step must not divide by it
    with pytest.raises(SingularSystemError, match="numerically singular"):
        solve_cholesky_schur(np.diag(np.full(3, np.inf)), np.arange(3.0), C=1.0)


@pytest.mark.parametrize("fit_intercept", [True, False])
def test_in_place_factorisation_gives_the_same_solution_and_only_then_destroys_k(fit_intercept):
    case = SVR_CASES[0]()
    K = gram(case.X, gamma=case.gamma)
    kept = K.copy()
    alpha, b, solution = solve_cholesky_schur(K, case.y, case.C, fit_intercept)
    np.testing.assert_array_equal(K, kept)  # the default leaves the caller's Gram matrix alone
    alpha_in_place, b_in_place, solution_in_place = solve_cholesky_schur(K, case.y, case.C, fit_intercept, overwrite_K=True)
    np.testing.assert_array_equal(alpha_in_place, alpha)
    assert b_in_place == b and solution_in_place.residuals == solution.residuals
    assert not np.array_equal(np.tril(K), np.tril(kept))  # the factor was written into K itself


def test_certificate_is_the_residual_of_the_full_system():
    case = SVR_CASES[1]()
    K = gram(case.X, gamma=case.gamma)
    alpha, b, solution = solve_cholesky_schur(K, case.y, case.C)
    system = kkt_system(K, case.y, case.C)
    direct = np.max(np.abs(system.M @ np.concatenate([[b], alpha]) - system.rhs))  # independent: the formed matrix
    # Both are rounding noise of the same size (a certificate read from the factored triangle is not).
    assert direct / 10 <= solution.residuals["primal"] <= 10 * direct + 1e-15
