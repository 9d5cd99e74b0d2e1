r"""``Guarded``: a regressor with calibrated prediction intervals and an input-domain guard.

For a fitted model :math:`\hat f`, coverage :math:`1 - \alpha` and the conformal quantile
:math:`q` of :mod:`svrqp.guard.conformal`,

.. math::

    [\hat f(x) - q\,\sigma(x),\ \hat f(x) + q\,\sigma(x)], \qquad \sigma \equiv 1
    \text{ for } \texttt{method="absolute"},

holds a new measurement with probability about :math:`1 - \alpha` while the new rows are
exchangeable with the calibration rows (between groups, when ``groups`` are given). Rows outside the
training domain (:mod:`svrqp.guard.domain`) break that premise: ``predict`` and
``predict_interval`` warn with :class:`svrqp.ExtrapolationWarning` for them.
"""

from __future__ import annotations

import warnings
from numbers import Real

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, RegressorMixin, clone, is_regressor
from sklearn.utils.validation import check_is_fitted, validate_data

from svrqp.exceptions import ExtrapolationWarning, ProblemError
from svrqp.guard import conformal
from svrqp.guard.domain import InputDomain, standardised
from svrqp.parameters import HasMethods, Number, OneOf, check_parameters


def _checked_groups(groups: ArrayLike, n_rows: int) -> NDArray:
    """``groups`` as a flat array of one label per row, all of one comparable type.

    Raises :class:`ProblemError` for a wrong length, missing labels, or labels that mix types
    (``[0, "a", 1]``: they cannot be sorted into folds, and ``1`` and ``"1"`` would be two groups).
    """
    groups = np.asarray(groups).ravel()
    if len(groups) != n_rows:
        raise ProblemError(f"groups has {len(groups)} labels for {n_rows} rows")
    if pd.isna(groups).any():
        raise ProblemError("groups: some labels are missing (NaN); give every row a group")
    if groups.dtype == object:
        kinds = {"text" if isinstance(label,
                                      str | bytes) else "number" if isinstance(label, Real) else
                 type(label).__name__ for label in groups}
        if len(kinds) > 1:
            raise ProblemError(f"groups: labels mix types ({', '.join(sorted(kinds))}); give every "
                               "row a label of the same type (all numbers or all text)")
        try:
            np.unique(groups)
        except TypeError as err:
            raise ProblemError(
                f"groups: labels cannot be ordered ({err}); give numbers or text"
            ) from None
    return groups


class Guarded(RegressorMixin, BaseEstimator):
    """Wrap a regressor with conformal prediction intervals and a training-domain check.

    Parameters
    ----------
    estimator
        Any scikit-learn regressor (an svrqp estimator, a ``Pipeline`` ending in one, ...).
    coverage
        Nominal coverage :math:`1 - \\alpha` of the intervals, in (0, 1).
    method
        ``"absolute"`` (interval :math:`\\hat f \\pm q`, the same width everywhere) or
        ``"normalized"`` (:math:`\\hat f \\pm q\\,\\sigma(x)`, wider where the out-of-fold errors
        are larger).
    n_splits
        Folds of the cross-validated calibration (whole groups when ``groups`` are given).
    min_groups
        Fewest distinct groups for group-aware calibration; with fewer, a
        :class:`~svrqp.guard.conformal.GroupFallbackWarning` says so and contiguous row folds
        are used.
    domain_quantile
        Quantile of the training rows' Mahalanobis distances used as the domain threshold
        (1.0: further out than every training row).

    Attributes
    ----------
    estimator_
        ``estimator`` refitted on every row; it makes the predictions.
    calibration_ : Calibration
        Folds, group labels, sorted scores, the quantile ``q`` and the difficulty model.
    domain_ : InputDomain
        Training ranges, standardisation, precision matrix and distance threshold.
    n_features_in_ : int
        Number of inputs.
    feature_names_in_ : ndarray of str
        Input names, when ``X`` was a DataFrame (the
        domain then names them; else ``x0``, ``x1``, ...).
    """

    _parameter_checks = {
        "estimator": [HasMethods(("fit", "predict"))],
        "coverage": [Number(0.0, 1.0)],
        "method": [OneOf(frozenset(conformal.METHODS))],
        "n_splits": [Number(2, closed="left", integer=True)],
        "min_groups": [Number(2, closed="left", integer=True)],
        "domain_quantile": [Number(0.0, 1.0, closed="right")],
    }

    def __init__(self, estimator, *, coverage=0.9, method="absolute", n_splits=10, min_groups=3,
                 domain_quantile=1.0):
        self.estimator = estimator
        self.coverage = coverage
        self.method = method
        self.n_splits = n_splits
        self.min_groups = min_groups
        self.domain_quantile = domain_quantile

    def _check_parameters(self) -> None:
        coverage = self.coverage
        if isinstance(coverage, bool) or not isinstance(coverage, Real) or not 0.0 < coverage < 1.0:
            raise ProblemError(f"coverage must be a number strictly between 0 and 1, got "
                               f"{coverage!r}")
        if not all(callable(getattr(self.estimator, method, None))
                   for method in ("fit", "predict")):
            raise ProblemError("estimator must be a scikit-learn regressor with fit and predict, "
                               f"got {self.estimator!r}")
        if not is_regressor(self.estimator):
            raise ProblemError(f"estimator must be a regressor, got "
                               f"{type(self.estimator).__name__} "
                               "(scikit-learn's is_regressor is false for it)")
        check_parameters(self, self._parameter_checks)

    def _inputs(self, X: ArrayLike, y: ArrayLike | None = None, *, fitting: bool):
        """Validate ``X`` (and ``y``) the scikit-learn way, then refuse non-finite rows by position.

        Returns the float array of ``X`` (and ``y`` when given); errors are ``ProblemError``.
        """
        try:
            if fitting:
                X_raw, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64,
                                         ensure_all_finite=False, ensure_min_samples=2)
            else:
                X_raw = validate_data(self, X, reset=False, dtype=np.float64,
                                      ensure_all_finite=False)
        except ValueError as err:
            raise ProblemError(str(err)) from None
        bad = np.flatnonzero(~np.isfinite(X_raw).all(axis=1))
        if len(bad):
            raise ProblemError(f"X: {len(bad)} row(s) hold NaN or infinite values (positions "
                               f"{bad[:10].tolist()}"
                               f"{', ...' if len(bad) > 10 else ''}); drop or fill them first")
        return X_raw if y is None else (X_raw, y)  # validate_data refused a non-finite y

    def _model_input(self, X_raw: NDArray[np.float64]):
        """What the wrapped model sees: a DataFrame with the fitted column names, or the array."""
        if hasattr(self, "feature_names_in_"):
            return pd.DataFrame(X_raw, columns=self.feature_names_in_)
        return X_raw

    def fit(self, X: ArrayLike, y: ArrayLike, groups: ArrayLike | None = None) -> Guarded:
        """Fit the model on every row and calibrate its intervals on out-of-fold residuals.

        Parameters
        ----------
        X : array-like (n, d)
            Inputs, raw units; a DataFrame's column names become the input names.
        y : array-like (n,)
            Target.
        groups : array-like (n,), optional
            Run/batch/cycle label per row: calibration folds are whole groups.
        """
        self._check_parameters()
        X_raw, y = self._inputs(X, y, fitting=True)
        if groups is not None:
            groups = _checked_groups(groups, len(y))
        names = [str(name) for name in getattr(self, "feature_names_in_",
                                               [f"x{j}" for j in range(X_raw.shape[1])])]
        self.domain_ = InputDomain.fit(X_raw, names, self.domain_quantile)
        Z = standardised(X_raw, self.domain_.mean, self.domain_.scale)
        inner = self._model_input(X_raw)
        settings = conformal.Settings(self.coverage, self.method, self.n_splits, self.min_groups)
        self.calibration_ = conformal.calibrate(self.estimator, inner, y, Z, groups, settings)
        self.estimator_ = clone(self.estimator).fit(inner, y)
        return self

    def _predict(self, X: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Raw inputs and predictions; warns (for the public caller) when rows are outside."""
        check_is_fitted(self)
        X_raw = self._inputs(X, fitting=False)
        outside = self.domain_.outside(X_raw)
        if outside.any():
            warnings.warn(ExtrapolationWarning(
                f"{int(outside.sum())} of {len(outside)} row(s) lie outside the training domain of "
                f"{', '.join(self.domain_.names)}; the model extrapolates there and the interval's "
                "coverage does not hold — see check_domain(X)"), stacklevel=3)
        return X_raw, np.asarray(self.estimator_.predict(self._model_input(X_raw)),
                                 dtype=float).ravel()

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """The wrapped model's prediction; warns with
        ExtrapolationWarning for rows outside the domain."""
        return self._predict(X)[1]

    def _half_width(self, X_raw: NDArray[np.float64]) -> NDArray[np.float64]:
        """:math:`q\\,\\sigma(x)` per row (``q`` everywhere for ``method="absolute"``)."""
        calibration = self.calibration_
        if calibration.difficulty_coef is None:
            return np.full(len(X_raw), calibration.quantile)
        Z = standardised(X_raw, self.domain_.mean, self.domain_.scale)
        return calibration.quantile * conformal.difficulty(Z, calibration.difficulty_coef,
                                                           calibration.difficulty_intercept)

    def predict_interval(self, X: ArrayLike) -> NDArray[np.float64]:
        """``(n, 2)``: lower and upper end of the interval per row (warns like :meth:`predict`)."""
        X_raw, prediction = self._predict(X)
        width = self._half_width(X_raw)
        return np.column_stack([prediction - width, prediction + width])

    def check_domain(self, X: ArrayLike) -> pd.DataFrame:
        """Per row: outside or not, which inputs, by how much (see :meth:`InputDomain.table`)."""
        check_is_fitted(self)
        table = self.domain_.table(self._inputs(X, fitting=False))
        table.index = X.index if isinstance(X, pd.DataFrame) else table.index
        return table

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags
