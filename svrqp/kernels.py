r"""Kernel functions and Gram matrices, and the RBF width conventions of the papers.

.. math::

    k_\text{linear}(x_i, x) = x_i \cdot x

    k_\text{poly}(x_i, x) = (\gamma\, x_i \cdot x + c)^d
    \qquad\text{(S0 eq. 4 is the case } \gamma = 1,\ c = 0\text{)}

    k_\text{rbf}(x_i, x) = \exp(-\gamma \lVert x_i - x \rVert^2)

The RBF width is written three ways in the literature:

* ``gamma`` — scikit-learn/libsvm: :math:`\exp(-\gamma\lVert\cdot\rVert^2)`;
* S0 (Miao 2013, eq. 4): :math:`\exp(-\lVert\cdot\rVert^2/\sigma^2)` with :math:`g = 1/\sigma^2`,
  so :math:`\gamma = g = 1/\sigma^2`;
* S4 (Lin 2011, eq. 6): :math:`\exp(-\lVert\cdot\rVert^2/(2\sigma^2))`, so :math:`\gamma = 1/(2\sigma^2)`.

All Gram matrices are computed with matrix products (no Python loops over samples).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from svrqp.exceptions import ProblemError

KernelName = Literal["linear", "poly", "rbf"]
KERNELS: tuple[str, ...] = ("linear", "poly", "rbf")


def _positive(value: float, name: str) -> float:
    value = float(value)
    if not np.isfinite(value) or value <= 0.0:
        raise ProblemError(f"{name} must be a finite positive number, got {value!r}")
    return value


def gamma_from_g(g: float) -> float:
    """S0's ``g = 1/σ²`` is scikit-learn's ``gamma`` unchanged."""
    return _positive(g, "g")


def gamma_from_sigma_s0(sigma: float) -> float:
    r"""``gamma`` for S0's :math:`\exp(-\lVert\cdot\rVert^2/\sigma^2)`: :math:`1/\sigma^2`."""
    return 1.0 / _positive(sigma, "sigma") ** 2


def gamma_from_sigma_s4(sigma: float) -> float:
    r"""``gamma`` for S4's :math:`\exp(-\lVert\cdot\rVert^2/(2\sigma^2))`: :math:`1/(2\sigma^2)`."""
    return 1.0 / (2.0 * _positive(sigma, "sigma") ** 2)


def sigma_s0_from_gamma(gamma: float) -> float:
    r"""S0's :math:`\sigma = 1/\sqrt{\gamma}`."""
    return 1.0 / np.sqrt(_positive(gamma, "gamma"))


def sigma_s4_from_gamma(gamma: float) -> float:
    r"""S4's :math:`\sigma = 1/\sqrt{2\gamma}`."""
    return 1.0 / np.sqrt(2.0 * _positive(gamma, "gamma"))


def rbf_conventions(gamma: float) -> dict[str, float]:
    """Every RBF width convention for one ``gamma``: ``gamma``, ``g``, ``sigma_s0``, ``sigma_s4``."""
    gamma = _positive(gamma, "gamma")
    return {
        "gamma": gamma,
        "g": gamma,
        "sigma_s0": sigma_s0_from_gamma(gamma),
        "sigma_s4": sigma_s4_from_gamma(gamma),
    }


def squared_distances(X: NDArray[np.float64], Y: NDArray[np.float64]) -> NDArray[np.float64]:
    r"""Pairwise :math:`\lVert x_i - y_j\rVert^2` by the expansion :math:`x^2 - 2x\cdot y + y^2`."""
    D = (
        np.einsum("ij,ij->i", X, X)[:, None]
        - 2.0 * (X @ Y.T)
        + np.einsum("ij,ij->i", Y, Y)[None, :]
    )
    # The expansion can go a few ulps below zero where points coincide.
    return np.maximum(D, 0.0, out=D)


def gram(
    X: ArrayLike,
    Y: ArrayLike | None = None,
    *,
    kernel: str = "rbf",
    gamma: float = 1.0,
    degree: int = 3,
    coef0: float = 0.0,
) -> NDArray[np.float64]:
    """Gram matrix :math:`K_{ij} = k(x_i, y_j)`.

    Parameters
    ----------
    X, Y
        Samples, shape ``(n, d)`` and ``(m, d)``; ``Y`` defaults to ``X``.
    kernel
        ``"linear"``, ``"poly"`` or ``"rbf"``.
    gamma, degree, coef0
        Kernel parameters (``gamma`` in scikit-learn's convention).

    Returns
    -------
    ndarray of shape ``(n, m)``
    """
    X = np.asarray(X, dtype=float)
    symmetric = Y is None
    Y = X if Y is None else np.asarray(Y, dtype=float)
    if X.ndim != 2 or Y.ndim != 2 or X.shape[1] != Y.shape[1]:
        raise ProblemError(f"X and Y must be 2-D with the same columns, got {X.shape} and {Y.shape}")
    with np.errstate(over="ignore", invalid="ignore"):
        if kernel == "linear":
            K = X @ Y.T
        elif kernel == "poly":
            _positive(gamma, "gamma")
            if int(degree) != degree or degree < 1:
                raise ProblemError(f"degree must be a positive integer, got {degree!r}")
            K = (gamma * (X @ Y.T) + coef0) ** int(degree)
        elif kernel == "rbf":
            _positive(gamma, "gamma")
            D = squared_distances(X, Y)
            if symmetric:  # exact symmetry and zero self-distance, which rounding breaks
                D = 0.5 * (D + D.T)
                np.fill_diagonal(D, 0.0)
            K = np.exp(-gamma * D)
        else:
            raise ProblemError(f"kernel must be one of {KERNELS}, got {kernel!r}")
    if not np.all(np.isfinite(K)):
        raise ProblemError(
            f"the {kernel} kernel overflows on these inputs (|X| up to {np.abs(X).max():.3g}): scale the features"
        )
    return K
