"""Second hostile campaign (issue #39): kernel parameters no user could mean are refused before
any work (a documented maximum degree, a bound on the polynomial kernel's values)."""

from __future__ import annotations


import numpy as np
import pytest

from svrqp import LSSVR, EpsilonSVR
from svrqp.exceptions import ProblemError, SolverError
from svrqp.kernels import MAX_DEGREE, gram
from svrqp.solvers import qp_backends


def sine_problem() -> tuple[np.ndarray, np.ndarray]:
    X = np.random.default_rng(0).uniform(-1, 1, (30, 2))
    return X, np.sin(3 * X[:, 0])


@pytest.mark.parametrize("model", [EpsilonSVR, LSSVR])
def test_degree_2_to_the_40_is_refused(model):
    """#10 and #12: libsvm's OverflowError for EpsilonSVR; LSSVR never returned (2**40 products).
    The refusal is a parameter check, so it comes before any kernel is formed (no time is asserted:
    a regression would hang the suite rather than fail it)."""
    X, y = sine_problem()
    with pytest.raises(ProblemError, match=f"degree.*\\[1, {MAX_DEGREE}\\]"):
        model(kernel="poly", degree=2**40).fit(X, y)


def test_gram_refuses_a_degree_above_the_maximum():
    X, _ = sine_problem()
    with pytest.raises(ProblemError, match="degree"):
        gram(X, kernel="poly", degree=MAX_DEGREE + 1)


@pytest.mark.parametrize("model", [EpsilonSVR, LSSVR])
def test_coef0_1e200_is_refused_before_the_solver(model):
    """#10: ``coef0=1e200`` reached libsvm, which failed with "dual coefficients are not finite"."""
    X, y = sine_problem()
    with pytest.raises(ProblemError, match="coef0"):
        model(kernel="poly", coef0=1e200).fit(X, y)


def test_high_degree_gram_matches_a_direct_power():
    """The single-pass power used above degree 8 gives the kernel's values."""
    X, _ = sine_problem()
    K = gram(X, kernel="poly", degree=MAX_DEGREE, gamma=0.5, coef0=1.0)
    np.testing.assert_allclose(K, (0.5 * X @ X.T + 1.0) ** MAX_DEGREE, rtol=1e-12)


def tiny_targets() -> tuple[np.ndarray, np.ndarray]:
    """#14's data: n = 10, y of order 1e-12 with ε = 1e-12 (a dual box 1e13 wide once scaled)."""
    X = np.random.default_rng(0).uniform(-1, 1, (10, 2))
    return X, 1e-12 * np.sin(3 * X[:, 0])


def test_backend_call_ends_at_its_time_limit_with_a_solver_error(monkeypatch):
    """#14: HiGHS ran for over 90 s; every backend call now has a time (or iteration) limit and
    ends in SolverError naming the backend. The limit is shortened here to keep the test quick."""
    monkeypatch.setattr(qp_backends, "TIME_LIMIT_S", 2.0)
    X, y = tiny_targets()
    with pytest.raises(SolverError, match="highs") as error:
        EpsilonSVR(C=10, epsilon=1e-12, gamma=1, solver="highs", fallback=False).fit(X, y)
    assert error.value.backend == "highs"


def test_tiny_targets_fall_back_to_a_certified_fit(monkeypatch):
    """#14 with the default fallback: after HiGHS stops, the exact interior point answers."""
    monkeypatch.setattr(qp_backends, "TIME_LIMIT_S", 2.0)
    X, y = tiny_targets()
    model = EpsilonSVR(C=10, epsilon=1e-12, gamma=1, solver="highs").fit(X, y)
    assert model.solver_ == "dual_ipm" and "highs" in model.fallback_reason_
    assert model.solution_.residuals["kkt_rel"] <= 1e-6


@pytest.mark.parametrize("scale, C", [(1e3, 10.0), (1.0, 1e6)])
def test_nearly_hard_margin_linear_fits_match_scikit_learn(scale, C):
    """Inputs of 1e3 (or C = 1e6) used to take minutes too (scikit-learn's libsvm still does); now a
    certified fit, equal to the primal QP solved by another path (Clarabel, or its fallback).
    Findings 14 and 15 against independent references: tests/estimators/test_adversarial_scale.py."""
    rng = np.random.default_rng(1)
    Z = rng.normal(size=(40, 3)) * scale
    y = Z @ [1.0, 2.0, 3.0] / scale + 0.1 * rng.normal(size=40)
    model = EpsilonSVR(C=C, kernel="linear").fit(Z, y)
    primal = EpsilonSVR(C=C, kernel="linear", formulation="primal").fit(Z, y)
    np.testing.assert_allclose(model.predict(Z), primal.predict(Z), rtol=0, atol=1e-5 * y.std())
