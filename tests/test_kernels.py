"""Kernels against scikit-learn's pairwise kernels, and the three RBF width conventions."""

import numpy as np
import pytest
from sklearn.metrics.pairwise import linear_kernel, polynomial_kernel, rbf_kernel

from svrqp import ProblemError
from svrqp.kernels import (
    gamma_from_g,
    gamma_from_sigma_s0,
    gamma_from_sigma_s4,
    gram,
    rbf_conventions,
    sigma_s0_from_gamma,
    sigma_s4_from_gamma,
)

RNG = np.random.default_rng(7)
X, Y = RNG.normal(size=(30, 3)), RNG.normal(size=(12, 3))


def test_gram_matrices_equal_scikit_learn():
    np.testing.assert_allclose(gram(X, Y, kernel="linear"), linear_kernel(X, Y), rtol=1e-12)
    np.testing.assert_allclose(gram(X, Y, kernel="poly", gamma=0.3, degree=3, coef0=1.5),
                               polynomial_kernel(X, Y, degree=3, gamma=0.3, coef0=1.5), rtol=1e-12)
    np.testing.assert_allclose(gram(X, Y, kernel="rbf", gamma=0.7), rbf_kernel(X, Y, gamma=0.7), rtol=1e-12, atol=1e-15)


def test_s0_polynomial_is_the_special_case():
    """S0 eq. 4: (x_i·x)^d is gamma = 1, c = 0."""
    np.testing.assert_allclose(gram(X, Y, kernel="poly", gamma=1.0, coef0=0.0, degree=2), (X @ Y.T) ** 2)


def test_rbf_conventions_are_the_same_function():
    sigma = 0.5946  # S2's σ
    d2 = np.sum((X[:, None, :] - Y[None, :, :]) ** 2, axis=-1)
    np.testing.assert_allclose(gram(X, Y, gamma=gamma_from_sigma_s0(sigma)), np.exp(-d2 / sigma**2))
    np.testing.assert_allclose(gram(X, Y, gamma=gamma_from_sigma_s4(sigma)), np.exp(-d2 / (2 * sigma**2)))
    assert gamma_from_g(0.125) == 0.125  # S0: g = 1/σ² is gamma
    conventions = rbf_conventions(0.125)
    assert conventions["sigma_s0"] == pytest.approx(sigma_s0_from_gamma(0.125))
    assert gamma_from_sigma_s4(sigma_s4_from_gamma(0.3)) == pytest.approx(0.3)
    assert gamma_from_sigma_s0(conventions["sigma_s0"]) == pytest.approx(0.125)


def test_gram_is_symmetric_and_exactly_one_on_the_diagonal():
    K = gram(X, gamma=2.0)
    np.testing.assert_array_equal(K, K.T)
    np.testing.assert_array_equal(np.diag(K), 1.0)


@pytest.mark.parametrize("kwargs, word", [
    ({"kernel": "sigmoid"}, "kernel"), ({"gamma": 0.0}, "gamma"), ({"gamma": -1.0}, "gamma"),
    ({"kernel": "poly", "degree": 0}, "degree"),
])
def test_bad_kernel_parameters(kwargs, word):
    with pytest.raises(ProblemError, match=word):
        gram(X, **kwargs)


def test_bad_shapes_and_widths():
    with pytest.raises(ProblemError, match="columns"):
        gram(X, Y[:, :2])
    with pytest.raises(ProblemError, match="sigma"):
        gamma_from_sigma_s4(0.0)
