"""Small fitted models (svrqp.estimators.fitted_state): pickle size against scikit-learn's SVR, and
problem_ / solution_ rebuilt after unpickling equal to what the fit produced."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from support.problems import SVR_CASES
from sklearn.svm import SVR

from svrqp import LSSVR, EpsilonSVR
from svrqp.formulations import epsilon_svr
from svrqp.kernels import gram

#: Pickle size allowed, as a multiple of scikit-learn's SVR for the same fitted model.
SIZE_RATIO = 3.0


def friedman_like(n: int = 1000, seed: int = 0):
    from sklearn.datasets import make_friedman1

    X, y = make_friedman1(n_samples=n, n_features=5, noise=1.0, random_state=seed)
    return (X - X.mean(axis=0)) / X.std(axis=0), (y - y.mean()) / y.std()


@pytest.mark.parametrize("solver", ["auto", "dual_ipm", "clarabel"])
def test_pickle_at_most_three_times_scikit_learn(solver):
    X, y = friedman_like()
    ours = EpsilonSVR(C=10.0, epsilon=0.1, gamma=0.2, solver=solver).fit(X, y)
    theirs = SVR(C=10.0, epsilon=0.1, gamma=0.2, tol=1e-8).fit(X, y)
    assert ours.support_.size == pytest.approx(theirs.support_.size, abs=2)  # the same fitted model
    ratio = len(pickle.dumps(ours)) / len(pickle.dumps(theirs))
    assert ratio <= SIZE_RATIO, ratio


@pytest.mark.parametrize("solver", ["auto", "clarabel"])
@pytest.mark.parametrize("formulation", ["split", "stacked"])
def test_unpickled_model_rebuilds_problem_and_certified_solution(solver, formulation):
    case = SVR_CASES[0]()
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, solver=solver,
                       formulation=formulation).fit(case.X, case.y)
    before = model.solution_
    loaded = pickle.loads(pickle.dumps(model))
    assert "_problem" not in loaded.__dict__ and "_solution" not in loaded.__dict__
    np.testing.assert_array_equal(loaded.predict(case.X), model.predict(case.X))
    # problem_: the QP of the formulation, built here independently from the training data
    expected = epsilon_svr.build(formulation, case.y, case.C, case.epsilon, K=gram(case.X, gamma=case.gamma))
    rebuilt = loaded.problem_
    P_rebuilt = rebuilt.P.toarray() if hasattr(rebuilt.P, "toarray") else rebuilt.P
    P_expected = expected.P.toarray() if hasattr(expected.P, "toarray") else expected.P
    np.testing.assert_allclose(P_rebuilt, P_expected, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(rebuilt.q, expected.q)
    assert rebuilt.name == expected.name
    # solution_: the point at the returned coefficients, certified on that QP
    solution = loaded.solution_
    assert solution.backend == before.backend and solution.status == before.status
    assert solution.x.shape == (expected.n,)
    assert solution.is_optimal(1e-8)
    residuals = expected.kkt_residuals(solution.x, solution.y, None, solution.z_box)
    assert residuals["gap_rel"] == pytest.approx(solution.residuals["gap_rel"], rel=1e-6, abs=1e-12)


def test_unpickled_linear_primal_keeps_its_solution():
    case = SVR_CASES[0]()
    model = EpsilonSVR(kernel="linear", C=1.0, epsilon=case.epsilon, formulation="primal").fit(case.X, case.y)
    loaded = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(loaded.solution_.x, model.solution_.x)
    assert loaded.problem_.name == model.problem_.name
    np.testing.assert_array_equal(loaded.problem_.h, model.problem_.h)


def test_unfitted_model_has_no_problem():
    assert not hasattr(EpsilonSVR(), "problem_") and not hasattr(EpsilonSVR(), "solution_")


@pytest.mark.parametrize("fit_intercept", [True, False])
def test_ls_svr_pickle_at_most_three_times_kernel_ridge(fit_intercept):
    from sklearn.kernel_ridge import KernelRidge

    X, y = friedman_like()
    ours = LSSVR(C=10.0, gamma=0.2, fit_intercept=fit_intercept).fit(X, y)
    theirs = KernelRidge(alpha=0.1, kernel="rbf", gamma=0.2).fit(X, y)
    if not fit_intercept:  # the same fitted model: LS-SVR without bias is kernel ridge with alpha = 1/C
        np.testing.assert_allclose(ours.dual_coef_[0], theirs.dual_coef_, rtol=1e-8, atol=1e-10)
    ratio = len(pickle.dumps(ours)) / len(pickle.dumps(theirs))
    assert ratio <= SIZE_RATIO, ratio


@pytest.mark.parametrize("kernel", ["rbf", "precomputed"])
@pytest.mark.parametrize("solver", ["cholesky", "lu"])
def test_unpickled_ls_svr_rebuilds_its_kkt_system(kernel, solver):
    from sklearn.metrics.pairwise import rbf_kernel

    X, y = friedman_like(n=60)
    K = rbf_kernel(X, gamma=0.3)
    data = K if kernel == "precomputed" else X
    model = LSSVR(C=5.0, kernel=kernel, gamma=0.3, solver=solver).fit(data, y)
    loaded = pickle.loads(pickle.dumps(model))
    assert "_problem" not in loaded.__dict__
    np.testing.assert_array_equal(loaded.predict(data), model.predict(data))
    # the bordered KKT matrix of S4 eq. (5), written here with plain numpy from scikit-learn's kernel
    n = y.size
    M = np.zeros((n + 1, n + 1))
    M[0, 1:] = M[1:, 0] = 1.0
    M[1:, 1:] = K + np.eye(n) / 5.0
    rebuilt = loaded.problem_
    np.testing.assert_allclose(rebuilt.M, M, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(rebuilt.rhs, np.concatenate([[0.0], y]))
    x = np.concatenate([loaded.intercept_, loaded.dual_coef_[0]])
    assert np.max(np.abs(M @ x - rebuilt.rhs)) <= 1e-8 * np.max(np.abs(y))


def test_unfitted_ls_svr_has_no_problem():
    assert not hasattr(LSSVR(), "problem_")
