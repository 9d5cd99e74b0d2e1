"""Kernels against scikit-learn's pairwise kernels, and the three RBF width conventions."""

import numpy as np
import pytest
from sklearn.metrics.pairwise import linear_kernel, polynomial_kernel, rbf_kernel

from svrqp import ProblemError, kernels
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

#: Each kernel with non-default parameters, and scikit-learn's function for it (the reference).
SKLEARN_KERNELS = [
    ({"kernel": "linear"}, linear_kernel),
    ({"kernel": "poly", "gamma": 0.3, "degree": 3, "coef0": 1.5},
     lambda A, B=None: polynomial_kernel(A, B, degree=3, gamma=0.3, coef0=1.5)),
    ({"kernel": "poly", "gamma": 0.8, "degree": 1, "coef0": -0.5},
     lambda A, B=None: polynomial_kernel(A, B, degree=1, gamma=0.8, coef0=-0.5)),
    ({"kernel": "rbf", "gamma": 0.7}, lambda A, B=None: rbf_kernel(A, B, gamma=0.7)),
]
#: Stable test ids (pytest-xdist workers must collect the same names; a function's repr holds its address).
SKLEARN_KERNEL_IDS = ["linear", "poly-degree-3", "poly-degree-1-negative-coef0", "rbf"]


@pytest.fixture
def tiny_blocks(monkeypatch):
    """Row blocks of 8 rows, so a 30-row Gram matrix is built from several blocks and a partial one."""
    monkeypatch.setattr(kernels, "BLOCK_ENTRIES", 8)


def test_gram_matrices_equal_scikit_learn():
    np.testing.assert_allclose(gram(X, Y, kernel="linear"), linear_kernel(X, Y), rtol=1e-12)
    np.testing.assert_allclose(gram(X, Y, kernel="poly", gamma=0.3, degree=3, coef0=1.5),
                               polynomial_kernel(X, Y, degree=3, gamma=0.3, coef0=1.5), rtol=1e-12)
    np.testing.assert_allclose(gram(X, Y, kernel="rbf", gamma=0.7), rbf_kernel(X, Y, gamma=0.7), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("parameters, reference", SKLEARN_KERNELS, ids=SKLEARN_KERNEL_IDS)
def test_blocked_gram_equals_scikit_learn_symmetric_and_rectangular(tiny_blocks, parameters, reference):
    np.testing.assert_allclose(gram(X, **parameters), reference(X), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(gram(X, Y, **parameters), reference(X, Y), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(gram(Y, X, **parameters), reference(Y, X), rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("parameters, reference", SKLEARN_KERNELS, ids=SKLEARN_KERNEL_IDS)
def test_training_gram_is_exactly_symmetric_for_every_kernel(tiny_blocks, parameters, reference):
    K = gram(X, **parameters)
    np.testing.assert_array_equal(K, K.T)


def test_rbf_of_far_points_underflows_to_zero_not_an_error():
    far = np.array([[0.0], [40.0]])
    np.testing.assert_array_equal(gram(far, gamma=1.0), np.eye(2))


@pytest.mark.parametrize("parameters", [{"kernel": "poly", "gamma": 1.0, "degree": 9},
                                        {"kernel": "linear"}])
def test_overflow_is_a_problem_error_not_inf(parameters):
    huge = np.full((3, 2), 1e160)
    with pytest.raises(ProblemError, match="overflows"):
        gram(huge, **parameters)


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
