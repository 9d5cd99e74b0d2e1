"""The ε-SVR's one home (svrqp.solvers.epsilon_svr): dispatch, fallback, and what is certified.

Issue 33's reproducer: on ``tests/data/svr_certificate_fail.csv`` the exact optimum of
``EpsilonSVR(C=10, epsilon=0.05, gamma=1.0)`` has one free coefficient of 5.9e-6, below the
interior-point zero cut 1e-6·min(C, max|β|) = 1e-5. Rounding the exact answer with that cut
dropped it, unbalanced 1ᵀβ = 0 by 5.9e-6 and failed dual_ipm, Clarabel and OSQP at the same
"gap certificate 2.31e-06", while ``solver="auto"`` (which does not round) passed.
"""

import numpy as np
import pandas as pd
import pytest
from sklearn.svm import SVR
from support.backends import require
from support.paths import REPO

from svrqp import EpsilonSVR, SolverError
from svrqp.formulations import epsilon_svr
from svrqp.kernels import gram
from svrqp.solvers.epsilon_svr import SolveOptions, SVRTask, solve_epsilon_svr

CASE = REPO / "tests" / "data" / "svr_certificate_fail.csv"
PARAMETERS = {"C": 10.0, "epsilon": 0.05, "gamma": 1.0}


@pytest.fixture(scope="module")
def case():
    table = pd.read_csv(CASE)
    return table[[f"x{i}" for i in range(8)]].to_numpy(), table["y"].to_numpy()


@pytest.fixture(scope="module")
def automatic(case):
    """The answer of ``solver="auto"`` (loose SMO and the exact crossover, never rounded)."""
    return EpsilonSVR(**PARAMETERS).fit(*case)


def full_beta(model, n):
    beta = np.zeros(n)
    beta[model.support_] = model.dual_coef_[0]
    return beta


@pytest.mark.parametrize("solver", ["dual_ipm", "clarabel", "osqp"])
def test_the_issue_33_case_certifies_with_each_exact_solver_and_keeps_its_small_support_vector(
        case, automatic, solver):
    if solver != "dual_ipm":
        require(solver)
    X, y = case
    model = EpsilonSVR(**PARAMETERS, solver=solver, fallback=False).fit(X, y)
    assert model.solver_ == solver and model.fallback_reason_ is None
    beta = full_beta(model, y.size)
    assert 1e-6 < np.min(np.abs(model.dual_coef_)) < 1e-5  # the free coefficient the old rounding dropped
    assert abs(beta.sum()) <= 1e-12 * PARAMETERS["C"]  # 1ᵀβ = 0, which dropping it broke by 5.9e-6
    # Independent of the path: the same support and coefficients as auto's SMO + crossover.
    np.testing.assert_array_equal(model.support_, automatic.support_)
    np.testing.assert_allclose(model.dual_coef_, automatic.dual_coef_, rtol=0, atol=1e-9)
    np.testing.assert_allclose(model.predict(X), automatic.predict(X), rtol=0, atol=1e-9)


def test_the_issue_33_answer_is_at_least_as_good_as_libsvm_at_tol_1e_8(case, automatic):
    """libsvm stops on its gradient test and leaves the 5.9e-6 coefficient at zero: its predictions
    differ by about that much, and its dual objective is not lower than the certified one."""
    X, y = case
    reference = SVR(**PARAMETERS, tol=1e-8).fit(X, y)
    K = gram(X, kernel="rbf", gamma=PARAMETERS["gamma"])
    ours = epsilon_svr.dual_objective(K, y, full_beta(automatic, y.size), PARAMETERS["epsilon"])
    theirs = epsilon_svr.dual_objective(K, y, full_beta(reference, y.size), PARAMETERS["epsilon"])
    assert ours <= theirs + 1e-12 * abs(theirs)
    np.testing.assert_allclose(automatic.predict(X), reference.predict(X), rtol=0, atol=1e-5 * y.std())


def test_an_exact_answer_keeps_a_small_free_coefficient_and_an_approximate_one_loses_it():
    C = 10.0
    beta = np.array([C * (1 - 1e-9), -C, 5.9e-6, 0.0, 2.0])
    exact = epsilon_svr.returned_coefficients(beta, C, exact=True)
    assert exact[2] == 5.9e-6 and exact[1] == -C and exact[0] == C * (1 - 1e-9)
    approximate = epsilon_svr.returned_coefficients(beta, C)
    assert approximate[2] == 0.0 and approximate[0] == C  # the interior point's slack is rounded away


def test_the_entry_falls_back_once_and_says_why(case):
    """A backend that cannot meet an impossible certificate falls back to dual_ipm, which is held
    to the same one and fails too: the error names both."""
    X, y = case
    task = SVRTask(PARAMETERS["C"], PARAMETERS["epsilon"], {"kernel": "rbf", "gamma": 1.0, "degree": 3,
                                                             "coef0": 0.0})
    fit = solve_epsilon_svr(X, y, task, SolveOptions(solver="dual_ipm"))
    assert fit.solver == "dual_ipm" and fit.fallback_reason is None and fit.problem is not None
    with pytest.raises(SolverError, match="the fallback 'dual_ipm' failed too"):
        solve_epsilon_svr(X, y, task, SolveOptions(solver="clarabel", check_tol=1e-300))
