"""ε-SVR cross-checks in three layers (DESIGN §3): backend status → independent KKT check →
scikit-learn's libsvm as the outside reference, for every formulation × backend × dataset."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sklearn.svm import SVR

from svrqp import EpsilonSVR
from svrqp.formulations.epsilon_svr import dual_objective
from svrqp.kernels import gram

from conftest import CHECK_TOLERANCE
from problems import SVR_CASES


def full_beta(model, n: int) -> np.ndarray:
    beta = np.zeros(n)
    beta[model.support_] = model.dual_coef_[0]
    return beta


def assert_kkt(K, y, beta, b, C, epsilon, tol):
    """The ε-SVR optimality conditions, checked here without the library's own helpers."""
    scale = 1.0 + np.abs(y).max()
    assert abs(beta.sum()) <= tol * C * len(y), "equality constraint sum(beta) = 0"
    assert np.all(np.abs(beta) <= C * (1 + tol)), "box constraint |beta| <= C"
    r = y - (K @ beta + b)
    inside = np.abs(beta) <= tol * C
    at_bound = np.abs(beta) >= C * (1 - tol)
    free = ~inside & ~at_bound
    assert np.all(np.abs(r[inside]) <= epsilon + tol * scale), "non-SVs lie inside the tube"
    assert np.allclose(r[free], epsilon * np.sign(beta[free]), atol=tol * scale), "free SVs on the tube"
    assert np.all(r[at_bound] * np.sign(beta[at_bound]) >= epsilon - tol * scale), "bounded SVs outside"


def reference(case, kernel="rbf"):
    return SVR(kernel=kernel, C=case.C, epsilon=case.epsilon, gamma=case.gamma, tol=1e-8).fit(case.X, case.y)


def linear(case):
    """The case with the C of its linear-kernel checks."""
    return dataclasses.replace(case, C=case.C_linear or case.C)


def assert_matches_reference(model, ref, case, K):
    n, std = len(case.y), case.y.std()
    ours, theirs = full_beta(model, n), full_beta(ref, n)
    f_ours, f_theirs = dual_objective(K, case.y, ours, case.epsilon), dual_objective(K, case.y, theirs, case.epsilon)
    assert abs(f_ours - f_theirs) <= 1e-6 * abs(f_theirs)
    assert np.max(np.abs(model.predict(case.X) - ref.predict(case.X))) <= 1e-5 * std
    assert abs(model.intercept_[0] - ref.intercept_[0]) <= 1e-5 * std
    # Support sets agree up to coefficients below 1e-7·C (DESIGN §3).
    differ = set(model.support_) ^ set(ref.support_)
    assert all(max(abs(ours[i]), abs(theirs[i])) < 1e-7 * case.C for i in differ), differ


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
@pytest.mark.parametrize("formulation", ["stacked", "split"])
def test_dual_matches_libsvm(case_factory, formulation, backend):
    case = case_factory()
    model = EpsilonSVR(C=case.C, epsilon=case.epsilon, gamma=case.gamma, solver=backend,
                       formulation=formulation, check_tol=CHECK_TOLERANCE.get(backend)).fit(case.X, case.y)
    assert model.solution_.status == "optimal"
    K = gram(case.X, gamma=case.gamma)
    assert_kkt(K, case.y, full_beta(model, len(case.y)), model.intercept_[0], case.C, case.epsilon, 1e-6)
    assert_matches_reference(model, reference(case), case, K)


@pytest.mark.parametrize("case_factory", SVR_CASES, ids=lambda f: f.__name__)
def test_linear_primal_matches_libsvm(case_factory, backend):
    case = linear(case_factory())
    model = EpsilonSVR(kernel="linear", C=case.C, epsilon=case.epsilon, solver=backend,
                       formulation="primal", check_tol=CHECK_TOLERANCE.get(backend)).fit(case.X, case.y)
    assert model.solution_.status == "optimal"
    K = gram(case.X, kernel="linear")
    beta = full_beta(model, len(case.y))
    # The weights of the primal equal X^T beta built from the multipliers (stationarity in w).
    np.testing.assert_allclose(model.coef_, case.X.T @ beta, atol=1e-5 * (1 + np.abs(model.coef_).max()))
    assert_matches_reference(model, reference(case, kernel="linear"), case, K)


def test_primal_and_duals_agree_on_linear_kernel():
    """Three formulations of one problem, one backend: the same model (a second, internal check)."""
    case = linear(SVR_CASES[1]())
    models = [EpsilonSVR(kernel="linear", C=case.C, epsilon=case.epsilon, formulation=f).fit(case.X, case.y)
              for f in ("primal", "split", "stacked")]
    predictions = [m.predict(case.X) for m in models]
    for other in predictions[1:]:
        np.testing.assert_allclose(other, predictions[0], atol=1e-6 * case.y.std())
