r"""Group-aware conformal calibration of prediction intervals (the conformal step by ``crepes``).

Out-of-fold residuals :math:`r_i = y_i - \hat f_{-k(i)}(x_i)` come from models refitted without
the fold :math:`k(i)` that holds row :math:`i`. With ``groups`` (runs, batches, thermal cycles)
the folds are whole groups (``GroupKFold``; leave-one-group-out up to ``n_splits`` groups), so
each residual is the error on a run the model has not seen: exchangeability is needed between
runs, not between the autocorrelated rows of one run. Without groups the folds are contiguous
blocks of rows (``KFold`` without shuffling).

The nonconformity score is :math:`|r_i|` (``method="absolute"``) or :math:`|r_i| / \sigma(x_i)`
(``method="normalized"``) with the difficulty

.. math::

    \sigma(x) = \exp\bigl(c_0 + c^\top z(x)\bigr),

a log-linear model of :math:`|r|` on the standardised inputs :math:`z` (least squares on
:math:`\log(|r| + \delta)`, :math:`\delta` = 1e-6 · mean :math:`|r|`). ``crepes``'
``ConformalRegressor`` turns the scores into the quantile :math:`q` — the
:math:`\lceil (n+1)(1-\alpha) \rceil`-th smallest of :math:`n` scores for coverage
:math:`1-\alpha` — and the interval is :math:`\hat f(x) \pm q` or :math:`\hat f(x) \pm q\,\sigma(x)`
around the model refitted on every row.

This is the cross-validation ("CV") conformal method: the full model is not one of the fold
models, so finite-sample coverage is approximate (exact for split conformal);
``benchmarks/guarded.py`` measures it. The difficulty model is fitted on the same residuals it
normalises (d + 1 coefficients), which can narrow intervals slightly.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from sklearn.base import clone
from sklearn.model_selection import GroupKFold, KFold

from svrqp.exceptions import ProblemError
from svrqp.extras import require

METHODS = ("absolute", "normalized")


class GroupFallbackWarning(UserWarning):
    """Too few groups for group-aware calibration: contiguous row folds are used instead."""


@dataclass(frozen=True)
class Calibration:
    """How the intervals were calibrated: folds, groups, scores and the conformal quantile."""

    folds: str
    n_splits: int
    groups: tuple[str, ...] | None
    scores: NDArray[np.float64]
    quantile: float
    difficulty_coef: NDArray[np.float64] | None
    difficulty_intercept: float | None


def folds(n: int, groups: NDArray | None, n_splits: int,
          min_groups: int) -> tuple[str, list, tuple[str, ...] | None]:
    """The folds (a description, a list of (train, test) index pairs, the group labels used)."""
    if groups is not None:
        labels = np.unique(groups)
        if len(labels) >= min_groups:
            k = min(n_splits, len(labels))
            name = "leave-one-group-out" if k == len(labels) else f"{k}-fold by group"
            return (
                name, list(GroupKFold(n_splits=k).split(np.zeros(n), groups=groups)),
                tuple(map(str, labels)),
            )
        warnings.warn(GroupFallbackWarning(
            f"groups: {len(labels)} group(s) given, group-aware calibration needs at least "
            f"{min_groups}; falling back to {n_splits} contiguous row folds, which assume "
            "exchangeable rows — intervals on a new run may be too narrow"), stacklevel=3)
    k = min(n_splits, n)
    return f"{k} contiguous row folds", list(KFold(n_splits=k).split(np.zeros(n))), None


def out_of_fold_predictions(estimator, X, y: NDArray[np.float64],
                            splits: list) -> NDArray[np.float64]:
    """Predictions of ``clone(estimator)`` refitted without each fold, on that fold."""
    prediction = np.empty(len(y))
    for train, test in splits:
        model = clone(estimator).fit(_rows(X, train), y[train])
        prediction[test] = model.predict(_rows(X, test))
    return prediction


def _rows(X, index: NDArray[np.intp]):
    return X.iloc[index] if hasattr(X, "iloc") else X[index]


def fit_difficulty(Z: NDArray[np.float64],
                   residuals: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
    """``(c, c0)`` of :math:`\\sigma(x) = \\exp(c_0 + c^\\top z)` by least squares on log |r|."""
    delta = 1e-6 * max(float(np.mean(np.abs(residuals))), np.finfo(float).tiny)
    A = np.column_stack([np.ones(len(Z)), Z])
    solution, *_ = np.linalg.lstsq(A, np.log(np.abs(residuals) + delta), rcond=None)
    return solution[1:], float(solution[0])


def difficulty(Z: NDArray[np.float64], coef: NDArray[np.float64],
               intercept: float) -> NDArray[np.float64]:
    """:math:`\\sigma(x) = \\exp(c_0 + c^\\top z)` per row."""
    return np.exp(intercept + Z @ coef)


def conformal_quantile(scores: NDArray[np.float64], coverage: float) -> float:
    """The conformal quantile of ``scores`` at ``coverage``, by ``crepes``."""
    n = len(scores)
    if (1.0 - coverage) * (n + 1) < 1.0:
        raise ProblemError(f"coverage {coverage} needs at least "
                           f"{math.ceil(1 / (1 - coverage)) - 1} calibration "
                           f"rows, got {n}: lower the coverage or give more rows")
    require("guard", "calibrated intervals")
    from crepes import ConformalRegressor

    regressor = ConformalRegressor().fit(residuals=scores, sigmas=np.ones(n))
    return float(regressor.predict_int(np.zeros(1), sigmas=np.ones(1), confidence=coverage)[0, 1])


@dataclass(frozen=True)
class Settings:
    """How a calibration runs: the target coverage, the score (``method``) and the folds."""

    coverage: float
    method: str
    n_splits: int
    min_groups: int


def calibrate(estimator, X, y: NDArray[np.float64], Z: NDArray[np.float64], groups: NDArray | None,
              settings: Settings) -> Calibration:
    """Out-of-fold residuals → scores → conformal quantile (see the module docstring)."""
    name, splits, labels = folds(len(y), groups, settings.n_splits, settings.min_groups)
    residuals = y - out_of_fold_predictions(estimator, X, y, splits)
    coef, intercept = (None, None)
    scores = np.abs(residuals)
    if settings.method == "normalized":
        coef, intercept = fit_difficulty(Z, residuals)
        scores = scores / difficulty(Z, coef, intercept)
    return Calibration(name, len(splits), labels, np.sort(scores),
                       conformal_quantile(scores, settings.coverage), coef, intercept)
