"""Second hostile campaign (issue #39): kernel parameters no user could mean are refused before
any work (a documented maximum degree, a bound on the polynomial kernel's values)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from svrqp import LSSVR, EpsilonSVR
from svrqp.exceptions import ProblemError
from svrqp.kernels import MAX_DEGREE, gram


def sine_problem() -> tuple[np.ndarray, np.ndarray]:
    X = np.random.default_rng(0).uniform(-1, 1, (30, 2))
    return X, np.sin(3 * X[:, 0])


@pytest.mark.parametrize("model", [EpsilonSVR, LSSVR])
def test_degree_2_to_the_40_is_refused_fast(model):
    """#10 and #12: libsvm's OverflowError for EpsilonSVR; LSSVR never returned (2**40 products)."""
    X, y = sine_problem()
    start = time.perf_counter()
    with pytest.raises(ProblemError, match=f"degree.*\\[1, {MAX_DEGREE}\\]"):
        model(kernel="poly", degree=2**40).fit(X, y)
    assert time.perf_counter() - start < 2.0


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
