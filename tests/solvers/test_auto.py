"""solver="auto" (svrqp.solvers.auto) and the loose-SMO + crossover path (svrqp.solvers.warm_start).

Cross-checks against scikit-learn's SVR(tol=1e-8) at the contract's tolerances (DESIGN §3), the
QP certificates computed without P against the generic QuadraticProgram.kkt_residuals, and the
bad-input contract: no certified path means SolverError naming every path tried.
"""

from __future__ import annotations

import numpy as np
import pytest
from support.epsilon_svr_reference import (
    assert_kkt,
    assert_matches_reference,
    full_beta,
    linear,
    reference,
)
from support.problems import SVR_CASES

from svrqp import EpsilonSVR, SolverError
from svrqp.formulations import epsilon_svr
from svrqp.formulations.epsilon_svr_certificate import dual_qp_point, multipliers
from svrqp.formulations.epsilon_svr_residuals import stated_dual
from svrqp.kernels import gram
from svrqp.solution import Solution, SolverRecord
from svrqp.solvers import auto as solver_choice
from svrqp.solvers.epsilon_svr import PRIMAL_AUTO_BACKEND


def sinc_case(n: int = 400, seed: int = 0):
    """Noisy sinc of the radius in 5 inputs: many free support vectors."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(-3.0, 3.0, (n, 5))
    y = np.sinc(np.linalg.norm(X, axis=1)) + rng.normal(0.0, 0.1, n)
    return X, y


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
@pytest.mark.parametrize("formulation", ["split", "stacked"])
def test_auto_matches_libsvm(case_factory, formulation):
    case = case_factory()
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, formulation=formulation).fit(case.X, case.y)
    assert model.solver_ in solver_choice.AUTO_ORDER
    assert model.solution_.is_optimal(1e-10)
    K = gram(case.X, gamma=case.gamma)
    assert_kkt(K, case.y, full_beta(model, len(case.y)), model.intercept_[0], case.C, case.epsilon, 1e-6)
    assert_matches_reference(model, reference(case), case, K)


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
def test_smo_crossover_linear_kernel_matches_libsvm(case_factory):
    case = linear(case_factory())
    model = EpsilonSVR(kernel="linear", C=case.C, epsilon=case.epsilon, solver="smo_crossover").fit(case.X, case.y)
    K = gram(case.X, kernel="linear")
    assert_kkt(K, case.y, full_beta(model, len(case.y)), model.intercept_[0], case.C, case.epsilon, 1e-6)
    assert_matches_reference(model, reference(case, kernel="linear"), case, K)


@pytest.mark.parametrize("C", [1.0, 100.0])
def test_smo_crossover_many_free_support_vectors(C):
    X, y = sinc_case()
    gamma = 0.2
    model = EpsilonSVR(C=C, epsilon=0.05, gamma=gamma, solver="smo_crossover").fit(X, y)
    from sklearn.svm import SVR

    libsvm = SVR(C=C, epsilon=0.05, gamma=gamma, tol=1e-8).fit(X, y)
    K = gram(X, gamma=gamma)
    ours, theirs = full_beta(model, y.size), full_beta(libsvm, y.size)
    f_ours = epsilon_svr.dual_objective(K, y, ours, 0.05)
    f_theirs = epsilon_svr.dual_objective(K, y, theirs, 0.05)
    assert f_ours <= f_theirs + 1e-8 * abs(f_theirs)  # minimised: never worse than libsvm's
    assert np.max(np.abs(model.predict(X) - libsvm.predict(X))) <= 1e-5 * y.std()
    assert model.solution_.settings["crossover_exact"] and model.solution_.is_optimal(1e-10)


@pytest.mark.parametrize("kernel", ["rbf", "poly", "linear"])
def test_small_fits_read_the_whole_gram_matrix_and_agree_with_the_column_cache(kernel, monkeypatch):
    """Up to DENSE_MAX_POINTS the loose run and the crossover read the Gram matrix formed at once
    (libsvm on it as a precomputed kernel): the same exact answer as libsvm on the inputs and the
    crossover through the column cache, to rounding."""
    from svrqp.solvers import warm_start

    X, y = sinc_case(n=300)
    assert y.size <= warm_start.DENSE_MAX_POINTS
    settings = {"C": 10.0, "epsilon": 0.05, "kernel": kernel, "gamma": 0.3, "solver": "smo_crossover"}
    dense = EpsilonSVR(**settings).fit(X, y)
    monkeypatch.setattr(warm_start, "DENSE_MAX_POINTS", 0)
    cached = EpsilonSVR(**settings).fit(X, y)
    assert dense.solution_.is_optimal(1e-10) and cached.solution_.is_optimal(1e-10)
    np.testing.assert_array_equal(dense.support_, cached.support_)
    assert np.max(np.abs(dense.predict(X) - cached.predict(X))) <= 1e-10 * y.std()


def test_precomputed_kernel_goes_through_auto():
    case = SVR_CASES[0]()
    K = gram(case.X, gamma=case.gamma)
    model = EpsilonSVR(kernel="precomputed", C=case.C, epsilon=case.epsilon).fit(K, case.y)
    from sklearn.svm import SVR

    ref = SVR(kernel="precomputed", C=case.C, epsilon=case.epsilon, tol=1e-8).fit(K, case.y)
    assert np.max(np.abs(model.predict(K) - ref.predict(K))) <= 1e-5 * case.y.std()


@pytest.mark.parametrize("formulation", ["split", "stacked"])
def test_certificates_without_P_equal_the_generic_ones(formulation):
    case = SVR_CASES[1]()
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, solver="clarabel").fit(case.X, case.y)
    K = gram(case.X, gamma=case.gamma)
    beta, b = full_beta(model, len(case.y)), model.intercept_[0]
    beta[0] += 1e-3 * case.C  # off the optimum, so that every certificate is non-trivial
    problem = epsilon_svr.build(formulation, case.y, case.C, case.epsilon, K=K)
    point = dual_qp_point(formulation, multipliers(beta, b, K @ beta, case.y, case.epsilon), case.C)
    expected = problem.kkt_residuals(*point[:2], None, point[2])
    stated = stated_dual(formulation, case.y, case.C, case.epsilon, beta, b, K @ beta, 1.0)
    solution = Solution.of_stated(stated, SolverRecord("test", "0"))
    residuals, objective = solution.residuals, solution.objective
    assert expected.keys() <= residuals.keys()
    for key, value in expected.items():
        # the dual residual is rounding by construction: K @ beta and P @ x round differently
        assert residuals[key] == pytest.approx(value, rel=1e-9, abs=1e-10), key
    assert objective == pytest.approx(problem.objective(point[0]), rel=1e-12)
    assert residuals["gap_rel"] > 1e-8  # the perturbation is seen


def test_auto_falls_back_to_dual_ipm_and_says_why(monkeypatch):
    def inexact(X, y, C, epsilon, kernel_parameters, tol):  # a warm start whose crossover did not settle
        n = y.size
        return np.zeros(n), 0.0, np.zeros(n), {"crossover_exact": False}, {}

    monkeypatch.setitem(solver_choice.PATHS, solver_choice.SMO_CROSSOVER, inexact)
    case = SVR_CASES[0]()
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma).fit(case.X, case.y)
    assert model.solver_ == "dual_ipm"
    assert "smo_crossover" in model.solution_.settings["rejected"][0]
    assert_matches_reference(model, reference(case), case, gram(case.X, gamma=case.gamma))


def test_auto_raises_when_no_path_certifies():
    case = SVR_CASES[0]()
    with pytest.raises(SolverError) as error:  # no path reaches a relative certificate of 1e-30
        EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, check_tol=1e-30).fit(case.X, case.y)
    assert all(path in str(error.value) for path in ("smo_crossover", "dual_ipm", "clarabel"))  # all tried
    with pytest.raises(SolverError):
        EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, check_tol=1e-30, fallback=False).fit(
            case.X, case.y)


def test_auto_falls_back_to_the_rescaled_backend_when_both_paths_fail(monkeypatch):
    def inexact(X, y, C, epsilon, kernel_parameters, tol):
        return np.zeros(y.size), 0.0, np.zeros(y.size), {"crossover_exact": False}, {}

    for path in solver_choice.AUTO_ORDER:
        monkeypatch.setitem(solver_choice.PATHS, path, inexact)
    case = SVR_CASES[0]()
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma).fit(case.X, case.y)
    assert model.solver_ == "clarabel" and "smo_crossover" in model.fallback_reason_
    assert_matches_reference(model, reference(case), case, gram(case.X, gamma=case.gamma))


@pytest.mark.parametrize("solver", ["clarabel", "dual_ipm", "osqp"])
def test_every_backend_stays_selectable(solver):
    case = SVR_CASES[2]()
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, solver=solver).fit(case.X, case.y)
    assert model.solver_ == model.solution_.backend == solver


def test_auto_on_the_linear_primal_uses_a_stock_backend():
    case = linear(SVR_CASES[0]())
    model = EpsilonSVR(kernel="linear", C=case.C, epsilon=case.epsilon, formulation="primal").fit(case.X, case.y)
    assert model.solver_ == PRIMAL_AUTO_BACKEND
