"""Predictions from an ``svrqp.model/1`` document alone.

The document's numbers are the only model state used: inputs are mapped to the model's coordinates
:math:`u = (x - \\text{mean}) / \\text{scale}` and then

.. math::

    f(x) = \\sum_i \\beta_i\\, k(u, s_i) + b \\quad\\text{(kernel kinds, S0 eq. (7))}, \\qquad
    f(x) = a^\\top u + b \\quad\\text{(linear kinds, S0 eq. (5))},

    f(x) = \\sum_{m=0}^{d} c_m P_m(t),\\ t = \\frac{2u - u_{\\min} - u_{\\max}}{u_{\\max} -
    u_{\\min}} \\quad\\text{(polynomial, Legendre basis)}.

The kernel is evaluated by :func:`svrqp.kernels.gram`, the same code the estimators use, so a
round trip through the file reproduces the estimator's predictions bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.polynomial import legendre
from numpy.typing import ArrayLike, NDArray

from svrqp import registry
from svrqp.exceptions import ProblemError
from svrqp.kernels import gram


def model_coordinates(document: dict[str, Any], X: ArrayLike) -> NDArray[np.float64]:
    """Raw inputs ``X`` (n, d) → the model's coordinates ``u`` (scaling applied)."""
    X = np.asarray(X, dtype=float)
    d = len(document["inputs"])
    if X.ndim != 2 or X.shape[1] != d:
        raise ProblemError(f"X must have shape (n, {d}) for inputs "
                           f"{[v['name'] for v in document['inputs']]}, got {X.shape}")
    scaling = document["scaling"]
    if scaling is None:
        return X
    return (X - np.asarray(scaling["mean"])) / np.asarray(scaling["scale"])


def _kernel_matrix(document: dict[str, Any], U: NDArray[np.float64]) -> NDArray[np.float64]:
    model = document["model"]
    kernel = model["kernel"]
    parameters = {key: kernel[key] for key in ("gamma", "degree",
                                               "coef0") if kernel[key] is not None}
    return gram(U, np.asarray(model["support_vectors"], dtype=float), kernel=kernel["name"],
                **parameters)


def _terms(document: dict[str, Any], X: ArrayLike) -> tuple[NDArray[np.float64], float]:
    """The summands of ``f`` per input row (n, m) and the constant term."""
    U = model_coordinates(document, X)
    model = document["model"]
    formula = registry.formula(document["kind"])
    if formula == registry.KERNEL:
        return _kernel_matrix(document, U) * np.asarray(model["dual_coef"]), model["intercept"]
    if formula == registry.LEGENDRE:
        low, high = model["domain"]
        t = (2.0 * U[:, 0] - low - high) / (high - low)
        return legendre.legvander(t, model["degree"]) * np.asarray(model["coef"]), 0.0
    return U * np.asarray(model["coef"]), model["intercept"]


#: Kernel entries formed at once when evaluating many rows (rows are taken in blocks): 32 MiB.
BLOCK_ENTRIES = 2**22


def row_blocks(n_rows: int, n_columns: int) -> list[slice]:
    """Slices of at most :data:`BLOCK_ENTRIES` // ``n_columns`` rows covering ``range(n_rows)``."""
    step = max(1, BLOCK_ENTRIES // max(n_columns, 1))
    return [slice(start, min(start + step, n_rows)) for start in range(0, n_rows, step)]


def support_inputs(document: dict[str, Any]) -> NDArray[np.float64]:
    """The support vectors of a kernel model in raw units (``u * scale + mean``)."""
    U = np.asarray(document["model"]["support_vectors"], dtype=float)
    scaling = document["scaling"]
    return U if scaling is None else U * np.asarray(scaling["scale"]) + np.asarray(scaling["mean"])


def predict(document: dict[str, Any], X: ArrayLike) -> NDArray[np.float64]:
    """Evaluate the model of ``document`` at raw inputs
    ``X`` of shape (n, d) (kernel models: by row blocks)."""
    return _by_row_blocks(document, np.asarray(X, dtype=float), _predict)


def _by_row_blocks(document: dict[str, Any], X: NDArray[np.float64],
                   evaluate: Callable[[dict[str, Any], NDArray[np.float64]], NDArray[np.float64]]
                   ) -> NDArray[np.float64]:
    """``evaluate(document, X)``, by row blocks for a kernel model whose kernel matrix with ``X``
    would pass :data:`BLOCK_ENTRIES` entries."""
    m = len(document["model"].get("support_vectors", ()))
    if (
        registry.formula(document["kind"]) == registry.KERNEL
        and X.ndim == 2
        and len(X) * m > BLOCK_ENTRIES
    ):
        return np.concatenate([evaluate(document, X[rows]) for rows in row_blocks(len(X), m)])
    return evaluate(document, X)


def _predict(document: dict[str, Any], X: ArrayLike) -> NDArray[np.float64]:
    U = model_coordinates(document, X)
    model = document["model"]
    formula = registry.formula(document["kind"])
    if formula == registry.KERNEL:
        return _kernel_matrix(document, U) @ np.asarray(model["dual_coef"]) + model["intercept"]
    if formula == registry.LEGENDRE:
        low, high = model["domain"]
        return legendre.legval((2.0 * U[:, 0] - low - high) / (high - low),
                               np.asarray(model["coef"]))
    return U @ np.asarray(model["coef"]) + model["intercept"]


def term_magnitude(document: dict[str, Any], X: ArrayLike) -> NDArray[np.float64]:
    """:math:`|b| + \\sum_i |\\text{term}_i|` per row: the scale of the rounding error of ``f``.

    Summing the terms in another order (another BLAS, the C evaluator) changes ``f`` by a few
    units in the last place of this magnitude, not of ``f`` itself, which may be much smaller.
    """
    return _by_row_blocks(document, np.asarray(X, dtype=float), _term_magnitude)


def _term_magnitude(document: dict[str, Any], X: NDArray[np.float64]) -> NDArray[np.float64]:
    terms, constant = _terms(document, X)
    return np.abs(terms).sum(axis=1) + abs(constant)
