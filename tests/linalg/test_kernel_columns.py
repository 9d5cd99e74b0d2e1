"""Kernel columns on demand equal the Gram matrix's columns and are computed once."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.metrics.pairwise import polynomial_kernel, rbf_kernel
from support.problems import diabetes

from svrqp import ProblemError
from svrqp.kernels import gram
from svrqp.linalg.kernel_columns import KernelColumns


@pytest.mark.parametrize("parameters", [{"kernel": "rbf", "gamma": 5.0}, {"kernel": "linear"},
                                        {"kernel": "poly", "gamma": 0.5, "degree": 2, "coef0": 1.0}])
def test_columns_and_diagonal_equal_the_gram_matrix(parameters):
    X = diabetes().X
    K = gram(X, **parameters)
    columns = KernelColumns(X, **parameters)
    idx = np.array([5, 0, 17, 5])
    np.testing.assert_allclose(columns(idx), K[:, idx], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(columns.diagonal(), np.diag(K), rtol=1e-12)


def test_cached_columns_are_not_recomputed():
    X = diabetes().X
    columns = KernelColumns(X, gamma=5.0)
    columns(np.array([1, 2, 3]))
    columns(np.array([3, 2, 4]))
    assert columns.evaluated == 4
    assert columns(np.array([], dtype=int)).shape == (X.shape[0], 0)


def test_a_block_of_rows_equals_scikit_learn_and_the_cached_columns():
    """``block`` serves K[rows, idx] from the cache; its first call also has to grow the store,
    the later ones read what earlier calls cached."""
    X = diabetes().X
    columns = KernelColumns(X, gamma=5.0)
    rows, idx = np.array([40, 3, 7, 3]), np.array([7, 3, 40, 11])
    np.testing.assert_allclose(columns.block(rows, idx), rbf_kernel(X[rows], X[idx], gamma=5.0),
                               rtol=1e-12, atol=1e-14)
    grown = np.arange(0, X.shape[0], 3)  # more columns than the store holds after the first call
    assert np.array_equal(columns.block(idx, grown), columns(grown)[idx])
    assert columns.evaluated == len(set(idx.tolist()) | set(grown.tolist()))


def test_columns_equal_scikit_learn_kernels():
    X = diabetes().X
    idx = np.array([3, 40, 7])
    np.testing.assert_allclose(KernelColumns(X, gamma=5.0)(idx), rbf_kernel(X, X[idx], gamma=5.0),
                               rtol=1e-12, atol=1e-14)
    poly = KernelColumns(X, kernel="poly", gamma=0.5, degree=3, coef0=1.0)(idx)
    np.testing.assert_allclose(poly, polynomial_kernel(X, X[idx], degree=3, gamma=0.5, coef0=1.0), rtol=1e-12)


def test_bad_parameters_are_rejected_when_the_cache_is_made():
    with pytest.raises(ProblemError, match="gamma"):
        KernelColumns(diabetes().X, gamma=-1.0)
    with pytest.raises(ProblemError, match="overflows"):
        KernelColumns(np.full((4, 2), 1e160), kernel="linear")(np.array([0]))


@pytest.mark.parametrize("parameters", [{"kernel": "rbf", "gamma": 5.0}, {"kernel": "linear"},
                                        {"kernel": "poly", "gamma": 0.5, "degree": 3, "coef0": 1.0}])
def test_products_equal_scikit_learn_kernel_times_vector(monkeypatch, parameters):
    from svrqp.linalg import kernel_columns

    monkeypatch.setattr(kernel_columns, "PRODUCT_BLOCK_ENTRIES", 200)  # several row blocks, a short last one
    X = diabetes().X
    idx = np.array([3, 40, 7, 100, 119, 3])  # few columns: plain row blocks over all points
    v = np.random.default_rng(0).uniform(-2.0, 2.0, idx.size)
    reference = {"rbf": lambda A, B: rbf_kernel(A, B, gamma=5.0), "linear": lambda A, B: A @ B.T,
                 "poly": lambda A, B: polynomial_kernel(A, B, degree=3, gamma=0.5, coef0=1.0)}[parameters["kernel"]]
    columns = KernelColumns(X, **parameters)
    np.testing.assert_allclose(columns.products(idx, v), reference(X, X[idx]) @ v, rtol=1e-12, atol=1e-13)
    assert columns.evaluated == 0  # the product's columns are not cached


@pytest.mark.parametrize("parameters", [{"kernel": "rbf", "gamma": 5.0}, {"kernel": "linear"},
                                        {"kernel": "poly", "gamma": 0.5, "degree": 2, "coef0": 1.0}])
def test_products_over_most_columns_use_symmetry_and_equal_numpy(monkeypatch, parameters):
    from svrqp.linalg import kernel_columns

    monkeypatch.setattr(kernel_columns, "PRODUCT_BLOCK_ENTRIES", 200)  # 14 x 14 tiles, short last ones
    X = diabetes().X
    rng = np.random.default_rng(1)
    idx = np.concatenate([rng.permutation(X.shape[0])[:250], [5, 5, 17]])  # most rows, some repeated
    assert np.unique(idx).size >= kernel_columns.SYMMETRIC_MIN_SHARE * X.shape[0]  # the tiled path
    v = rng.uniform(-2.0, 2.0, idx.size)
    K = gram(X, **parameters)
    columns = KernelColumns(X, **parameters)
    np.testing.assert_allclose(columns.products(idx, v), K[:, idx] @ v, rtol=1e-12, atol=1e-12)
    assert np.array_equal(columns.products(np.array([], dtype=int), np.zeros(0)), np.zeros(X.shape[0]))


@pytest.mark.parametrize("idx", [[0], [0, 1, 2, 3, 4]])  # plain row blocks, symmetric tiles
def test_products_reject_an_overflowing_kernel(idx):
    X = np.full((20, 2), 1e160)  # checked once on the product, not on every block
    with pytest.raises(ProblemError, match="overflows"):
        KernelColumns(X, kernel="linear").products(np.array(idx), np.eye(len(idx))[0])
