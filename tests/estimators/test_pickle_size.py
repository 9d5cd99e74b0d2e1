"""Small fitted models (svrqp.estimators.fitted_state): pickle size against scikit-learn's SVR, and
problem_ / solution_ rebuilt after unpickling (once given the fit's data) equal to what the fit produced."""

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


def warm_up_like(n: int = 2000, seed: int = 0):
    """Smooth warm-up curves read by ten noisy sensors: few support vectors (47 of 2000 at C = 1)."""
    rng = np.random.default_rng(seed)
    t_min = rng.uniform(0.0, 250.0, n)
    T_C = 20.0 + rng.uniform(2.0, 10.0, 10) * (1.0 - np.exp(-t_min[:, None] / rng.uniform(20.0, 120.0, 10)))
    T_C += rng.normal(0.0, 0.05, T_C.shape)
    error_um = 3.0 * (T_C[:, 0] - 20.0) - 1.2 * (T_C[:, 3] - 20.0) + rng.normal(0.0, 0.2, n)
    return (T_C - T_C.mean(axis=0)) / T_C.std(axis=0), (error_um - error_um.mean()) / error_um.std()


@pytest.mark.parametrize(("data", "solver", "C", "gamma"), [
    (friedman_like, "auto", 10.0, 0.2), (friedman_like, "dual_ipm", 10.0, 0.2), (friedman_like, "clarabel", 10.0, 0.2),
    (warm_up_like, "auto", 1.0, 0.1)])  # many support vectors, then few
def test_pickle_at_most_three_times_scikit_learn(data, solver, C, gamma):
    X, y = data()
    ours = EpsilonSVR(C=C, epsilon=0.1, gamma=gamma, solver=solver).fit(X, y)
    theirs = SVR(C=C, epsilon=0.1, gamma=gamma, tol=1e-8).fit(X, y)
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
    held = dict(model.__dict__)
    loaded = pickle.loads(pickle.dumps(model))
    assert all(model.__dict__[key] is value for key, value in held.items())  # pickling leaves the model as it was
    assert "_problem" not in loaded.__dict__ and "_solution" not in loaded.__dict__
    np.testing.assert_array_equal(loaded.predict(case.X), model.predict(case.X))
    with pytest.raises(AttributeError, match="with_training_data"):
        loaded.problem_  # noqa: B018 - the pickle does not carry the training rows
    assert loaded.solution_.x is None and loaded.solution_.residuals == before.residuals  # the record alone
    del loaded.__dict__["_solution"]
    with pytest.raises(ValueError, match="not the data"):
        loaded.with_training_data(case.X, case.y[::-1])
    assert loaded.with_training_data(case.X, case.y) is loaded
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
    loaded.with_training_data(case.X, case.y)
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
