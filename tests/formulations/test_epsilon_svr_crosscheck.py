"""ε-SVR cross-checks in three layers (DESIGN §3): backend status → independent KKT check →
scikit-learn's libsvm as the outside reference, for every formulation × backend × dataset."""

from __future__ import annotations

import numpy as np
import pytest
from support.backends import CHECK_TOLERANCE
from support.epsilon_svr_reference import (
    assert_kkt,
    assert_matches_reference,
    full_beta,
    linear,
    reference,
)
from support.problems import SVR_CASES

from svrqp import EpsilonSVR
from svrqp.kernels import gram


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
