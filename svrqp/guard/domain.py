r"""The input domain of a fitted model: per-input training range and a Mahalanobis distance.

A row :math:`x \in \mathbb{R}^d` is **outside** the domain when

.. math::

    \exists j:\ x_j < \ell_j \ \text{or}\ x_j > h_j
    \qquad\text{or}\qquad
    D(x) = \sqrt{z^\top P z} > \tau,\quad z = (x - \mu) \oslash s,

with :math:`\ell, h` the per-input minimum and maximum over the training rows, :math:`\mu, s`
their mean and standard deviation, :math:`P` the inverse of the covariance matrix of the
standardised training inputs (eigenvalues floored at :data:`EIGENVALUE_FLOOR` times the largest,
so collinear sensors give a finite, very strict :math:`P`) and :math:`\tau` the ``quantile`` of the
training rows' own distances (1.0: the largest, i.e. further out than every training row),
widened by a relative :data:`ROUNDING_MARGIN` of 1e-9.

The range says *which input* left the training conditions and by how much (in that input's
units); the distance catches a combination never seen, e.g. two usually correlated sensors that
disagree, each within its own range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from svrqp.exceptions import ProblemError

#: Relative margin on the threshold: the training row at the quantile stays inside in any
#: evaluator (numpy, the exported C) although each sums D's terms in its own order.
ROUNDING_MARGIN = 1e-9

#: Smallest eigenvalue kept in the covariance of the standardised inputs, relative to the largest.
EIGENVALUE_FLOOR = 1e-9


def standardised(X: NDArray[np.float64], mean: NDArray[np.float64],
                 scale: NDArray[np.float64]) -> NDArray[np.float64]:
    """:math:`z = (x - \\mu) \\oslash s`, row by row."""
    return (X - mean) / scale


def mahalanobis(Z: NDArray[np.float64], precision: NDArray[np.float64]) -> NDArray[np.float64]:
    """:math:`D = \\sqrt{z^\\top P z}` per row of standardised inputs ``Z`` (n, d)."""
    return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", Z, precision, Z), 0.0))


def outside_rows(X: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64],
                 mean: NDArray[np.float64], scale: NDArray[np.float64],
                 precision: NDArray[np.float64], threshold: float) -> NDArray[np.bool_]:
    """True per row outside ``[low, high]`` in some
    input or with :math:`D(x) > \tau` (NaN: outside)."""
    in_range = np.all((X >= low) & (X <= high), axis=1)
    return ~(in_range & (mahalanobis(standardised(X, mean, scale), precision) <= threshold))


@dataclass(frozen=True)
class InputDomain:
    """The fitted domain (all arrays per input, raw units for ``low``/``high``)."""

    names: tuple[str, ...]
    low: NDArray[np.float64]
    high: NDArray[np.float64]
    mean: NDArray[np.float64]
    scale: NDArray[np.float64]
    precision: NDArray[np.float64]
    threshold: float
    quantile: float

    @classmethod
    def fit(cls, X: NDArray[np.float64], names: list[str], quantile: float = 1.0) -> InputDomain:
        """The domain of training inputs ``X`` (n, d), finite."""
        if not 0.0 < quantile <= 1.0:
            raise ProblemError(f"domain_quantile must be in (0, 1], got {quantile!r}")
        mean = X.mean(axis=0)
        scale = X.std(axis=0)
        scale = np.where(scale > 0, scale, 1.0)  # a constant input: its range alone decides
        Z = standardised(X, mean, scale)
        eigenvalues, vectors = np.linalg.eigh(np.atleast_2d(np.cov(Z, rowvar=False, bias=True)))
        eigenvalues = np.maximum(eigenvalues, EIGENVALUE_FLOOR * max(eigenvalues.max(), 1.0))
        precision = (vectors / eigenvalues) @ vectors.T
        precision = (precision + precision.T) / 2.0
        quantile_distance = float(np.quantile(mahalanobis(Z, precision), quantile, method="higher"))
        threshold = quantile_distance * (1.0 + ROUNDING_MARGIN)
        return cls(tuple(names), X.min(axis=0), X.max(axis=0), mean, scale, precision, threshold,
                   quantile)

    def distance(self, X: ArrayLike) -> NDArray[np.float64]:
        """Mahalanobis distance :math:`D(x)` of each row."""
        return mahalanobis(standardised(np.asarray(X, dtype=float), self.mean, self.scale),
                           self.precision)

    def outside(self, X: ArrayLike) -> NDArray[np.bool_]:
        """True for each row outside the range of some input or beyond the distance threshold."""
        return outside_rows(np.asarray(X, dtype=float), self.low, self.high, self.mean, self.scale,
                            self.precision, self.threshold)

    def table(self, X: ArrayLike) -> pd.DataFrame:
        """Per row: outside or not, which inputs left their range, by how much, and the distance.

        Columns: ``outside``, ``inputs_outside`` (names, comma-separated), ``excess_<name>`` (how
        far beyond the training range, in the input's units; negative below the minimum, 0
        inside), ``distance`` and ``distance_threshold`` (Mahalanobis, standardised units).
        """
        X = np.asarray(X, dtype=float)
        excess = np.where(X > self.high, X - self.high, np.where(X < self.low, X - self.low, 0.0))
        distance = self.distance(X)
        table = pd.DataFrame(
            {
                "outside": self.outside(X), "inputs_outside": [
                    ", ".join(n for n, e in zip(self.names, row, strict=True) if e != 0.0)
                    for row in excess
                ], **{f"excess_{name}": excess[:, j] for j, name in enumerate(self.names)},
                "distance": distance, "distance_threshold": self.threshold,
            }
        )
        return table
