"""scikit-learn regressors over the least-squares formulations.

- :class:`LinearLS` — multiple linear regression by the normal equations (S0 eq. (5)), with a
  coefficient table and the fitted formula in LaTeX (``S = 3.7674\\,T_7 - 0.4237\\,T_9 - 2.7669``).
- :class:`PolynomialLS` — a one-variable polynomial on the Legendre basis (S2 eq. (22)).
- :class:`RecursiveLS` — recursive least squares with ``partial_fit`` and a forgetting factor
  (S3 eqs. (13)–(19)); :func:`merge_models` merges two of them (S3 eqs. (20)–(24)).

Units are read from column names that follow the project's convention (``T7_C``, ``error_um``,
``x_mm``) or the ``name(unit)`` form of measured
tables (``t1(°C)``, ``ch1(um)``): :mod:`svrqp.units`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils.validation import check_is_fitted, validate_data

from svrqp import description
from svrqp.exceptions import ProblemError, input_errors_as_problem_errors
from svrqp.formulations import least_squares, recursive_ls
from svrqp.parameters import Boolean, Number, OneOf, check_parameters
from svrqp.table_checks import check_magnitude, check_numeric_array
from svrqp.units import latex_symbol, ratio_unit, split_unit

#: How :class:`LinearLS` and :class:`PolynomialLS`
#: solve (the ``solver`` of their exported documents).
NORMAL_EQUATIONS = "normal equations, equilibrated, Cholesky (svrqp.formulations.least_squares)"
#: How :class:`RecursiveLS` solves.
RECURSION = "recursive least squares (S3 eqs. 13-17), started from the batch normal equations"


class _LinearFormula:
    """Coefficient table and LaTeX formula of a fitted ``y = intercept_ + X @ coef_``."""

    def _feature_names(self) -> list[str]:
        if hasattr(self, "feature_names_in_"):
            return [str(name) for name in self.feature_names_in_]
        return [f"x{j}" for j in range(self.n_features_in_)]

    def coefficient_table(self, target_unit: str | None = None) -> pd.DataFrame:
        """The fitted coefficients with their units.

        Parameters
        ----------
        target_unit : str, optional
            Unit of the target; by default read from the target's name at fit time.

        Returns
        -------
        DataFrame
            Columns ``name``, ``value``, ``unit``; one row per feature, then ``intercept``.
        """
        check_is_fitted(self)
        if target_unit is None:
            target_unit = split_unit(self.target_name_)[1] if self.target_name_ else ""
        names = self._feature_names()
        units = [ratio_unit(target_unit, split_unit(name)[1]) for name in names]
        return pd.DataFrame({
            "name": [*names, "intercept"],
            "value": [*map(float, self.coef_), float(self.intercept_)],
            "unit": [*units, target_unit],
        })

    def to_latex(self, target_symbol: str | None = None, digits: int = 4) -> str:
        """The fitted formula, e.g. ``S = 3.7674\\,T_7 - 0.4237\\,T_9 - 2.7669``.

        Parameters
        ----------
        target_symbol : str, optional
            Left-hand side; by default the symbol of the target's name, or ``y``.
        digits : int
            Decimals of every coefficient.
        """
        check_is_fitted(self)
        if target_symbol is None:
            target_symbol = latex_symbol(self.target_name_) if self.target_name_ else "y"
        terms = [(float(value), r"\," + latex_symbol(name))
                 for value, name in zip(self.coef_, self._feature_names(), strict=True)]
        if self.intercept_ != 0.0:
            terms.append((float(self.intercept_), ""))
        if not terms:
            return f"{target_symbol} = 0"
        text = ""
        for position, (value, symbol) in enumerate(terms):
            sign = "-" if value < 0 else ("+" if position else "")
            separator = f" {sign} " if position else sign
            text += f"{separator}{abs(value):.{digits}f}{symbol}"
        return f"{target_symbol} = {text}"


def _target_name(y: ArrayLike) -> str:
    name = getattr(y, "name", None)
    return str(name) if name is not None else ""


def _finite_training_data(estimator: BaseEstimator, X: ArrayLike, y: ArrayLike, reset: bool
                          ) -> tuple[NDArray, NDArray]:
    # NaN and text must raise the library's ProblemError,
    # so they are looked for before sklearn does.
    check_numeric_array(X, "X")
    check_numeric_array(y, "y")
    y_values = np.asarray(y)
    if y_values.dtype.kind == "f":
        least_squares.check_finite_matrix(y_values.reshape(-1), "y", 1)
    with input_errors_as_problem_errors():
        X, y = validate_data(estimator, X, y, reset=reset, y_numeric=True, dtype=np.float64,
                             ensure_all_finite=False)
    y = y.astype(np.float64, copy=False)  # boolean or integer targets
    check_magnitude(X, "X")
    check_magnitude(y, "y")
    return (least_squares.check_finite_matrix(X, "X", 2),
            least_squares.check_finite_matrix(y, "y", 1))


def _finite_inputs(estimator: BaseEstimator, X: ArrayLike) -> NDArray:
    check_is_fitted(estimator)
    check_numeric_array(X, "X")
    with input_errors_as_problem_errors():
        X = validate_data(estimator, X, reset=False, dtype=np.float64, ensure_all_finite=False)
    check_magnitude(X, "X")
    return least_squares.check_finite_matrix(X, "X", 2)


class LinearLS(_LinearFormula, RegressorMixin, BaseEstimator):
    """Multiple linear regression by the normal equations (S0 eq. (5), S3 eq. (6)).

    Parameters
    ----------
    fit_intercept : bool, default=True
        Fit the constant term (by centring, see :mod:`svrqp.formulations.least_squares`).
    rank_deficient : {"raise", "lstsq"}, default="raise"
        A rank-deficient design raises :class:`~svrqp.exceptions.SingularSystemError` naming the
        columns, unless ``"lstsq"`` asks for the minimum-norm answer.

    Attributes
    ----------
    coef_ : ndarray of shape (n_features,)
    intercept_ : float
    x_centre_ : ndarray of shape (n_features,)
        The centre :math:`\\bar x` of the training inputs (zeros without an intercept):
        ``predict`` evaluates :math:`\\bar y + (x - \\bar x)^\\top a`, which keeps its digits when
        the inputs are offset far from zero (``intercept_ + X @ coef_`` would not).
    centre_value_ : float
        The prediction at ``x_centre_`` (:math:`\\bar y`; 0 without an intercept).
    rank_ : int
        Numerical rank of the (centred) design.
    condition_number_ : float
        Condition number of the equilibrated normal matrix.
    target_name_ : str
        Name of ``y`` when it was a named pandas Series, else ``""``.
    """

    export_kind = "linear_ls"
    _parameter_checks = {
        "fit_intercept": [Boolean()],
        "rank_deficient": [OneOf(frozenset({"raise", "lstsq"}))],
    }

    def __init__(self, *, fit_intercept=True, rank_deficient="raise"):
        self.fit_intercept = fit_intercept
        self.rank_deficient = rank_deficient

    def export_sections(self) -> description.Sections:
        """The ``model`` and ``solver`` sections of its
        exported document (:mod:`svrqp.description`)."""
        return description.Sections(
            description.linear_model(self.coef_, self.centre_value_, self.fit_intercept),
            description.least_squares_solver(
                NORMAL_EQUATIONS, self.get_params(),
                {"condition_number": self.condition_number_, "rank": self.rank_},
            ), centre=self.x_centre_ if self.fit_intercept else None,
        )

    def fit(self, X: ArrayLike, y: ArrayLike) -> LinearLS:
        """Solve the normal equations for (X, y).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,)
        """
        check_parameters(self, self._parameter_checks)
        target_name = _target_name(y)
        X, y = _finite_training_data(self, X, y, reset=True)
        names = self._feature_names()
        fit = least_squares.fit_linear(X, y, fit_intercept=self.fit_intercept,
                                       rank_deficient=self.rank_deficient, column_names=names)
        self.coef_ = fit.coef
        self.intercept_ = fit.intercept
        self.x_centre_ = fit.x_centre if fit.x_centre is not None else np.zeros(X.shape[1])
        self.centre_value_ = fit.centre_value
        self.rank_ = fit.rank
        self.condition_number_ = fit.condition_number
        self.target_name_ = target_name
        return self

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Predict :math:`a_0 + X a`, evaluated as
        :math:`\\bar y + (X - \\bar x) a` (see ``x_centre_``)."""
        return (_finite_inputs(self, X) - self.x_centre_) @ self.coef_ + self.centre_value_


class PolynomialLS(RegressorMixin, BaseEstimator):
    """Least-squares polynomial in one variable on the Legendre basis (S2 eq. (22)).

    Parameters
    ----------
    degree : int, default=5
        Polynomial degree (S2 uses 5 for δx over 0–550 mm).

    Attributes
    ----------
    legendre_coef_ : ndarray of shape (degree + 1,)
        Coefficients of :math:`P_0 \\dots P_d` in :math:`u \\in [-1, 1]`.
    domain_ : tuple of float
        The training range of ``x`` mapped onto :math:`[-1, 1]`.
    condition_number_ : float
        Condition number of the equilibrated Legendre normal matrix.
    """

    export_kind = "polynomial_ls"
    _parameter_checks = {"degree": [Number(0, closed="left", integer=True)]}

    def __init__(self, *, degree=5):
        self.degree = degree

    def export_sections(self) -> description.Sections:
        """The ``model`` and ``solver`` sections of its
        exported document (:mod:`svrqp.description`)."""
        return description.Sections(
            description.polynomial_model(self.degree, self.domain_, self.legendre_coef_),
            description.least_squares_solver(NORMAL_EQUATIONS, self.get_params(),
                                             {"condition_number": self.condition_number_}))

    def fit(self, X: ArrayLike, y: ArrayLike) -> PolynomialLS:
        """Fit the polynomial to one input column.

        Parameters
        ----------
        X : array-like of shape (n_samples, 1)
        y : array-like of shape (n_samples,)
        """
        check_parameters(self, self._parameter_checks)
        X, y = _finite_training_data(self, X, y, reset=True)
        if X.shape[1] != 1:
            raise ProblemError(f"PolynomialLS models one variable; X has {X.shape[1]} features")
        fit = least_squares.fit_polynomial(X[:, 0], y, self.degree)
        self.legendre_coef_ = fit.legendre_coef
        self.domain_ = fit.domain
        self.condition_number_ = fit.condition_number
        return self

    def _fit_result(self) -> least_squares.PolynomialFit:
        check_is_fitted(self)
        return least_squares.PolynomialFit(self.legendre_coef_, self.domain_,
                                           self.condition_number_)

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Evaluate the polynomial at ``X[:, 0]``."""
        return self._fit_result().predict(_finite_inputs(self, X)[:, 0])

    def to_polynomial(self) -> np.polynomial.Polynomial:
        """The fitted polynomial as a numpy ``Polynomial`` (power basis, with domain)."""
        return self._fit_result().to_polynomial()


class RecursiveLS(_LinearFormula, RegressorMixin, BaseEstimator):
    """Recursive least squares for :math:`y = a_0 + x^\\top a` (S3 eqs. (13)–(19)).

    ``partial_fit`` absorbs samples one by one through the recursion. Until the samples seen so
    far determine every coefficient well (see
    :func:`svrqp.formulations.recursive_ls.initial_prefix`), they are pooled and the model is not
    fitted yet; the recursion then starts from the exact batch solution of that pool.

    The recursion runs on the regressors :math:`(1, x - x_\\mathrm{ref})`, with
    :math:`x_\\mathrm{ref}` the first sample (``x_offset_``): the same model, but without the large
    common offset of temperatures near 30 °C that would otherwise dominate the information
    matrix and cost digits at every step. ``coef_`` and ``intercept_`` are in the original units;
``predict`` evaluates the model on those regressors (inputs offset by 1.7e9 keep their digits).

    Parameters
    ----------
    forgetting : float, default=1.0
        Forgetting factor :math:`\\lambda \\in (0, 1]`; 1 is S3's method, smaller values follow a
        drifting machine (memory of about :math:`1/(1-\\lambda)` samples).

    Attributes
    ----------
    coef_ : ndarray of shape (n_features,)
    intercept_ : float
    x_offset_ : ndarray of shape (n_features,)
        Reference :math:`x_\\mathrm{ref}` of the regressors the recursion runs on.
    state_ : RecursiveLSState
        The recursion state for the regressors :math:`(1, x - x_\\mathrm{ref})`.
    sigma2_ : float
        Residual variance by S3 eq. (19) (NaN while there are no more samples than parameters).
    n_samples_seen_ : int
        Samples absorbed into the model.
    target_name_ : str
    """

    export_kind = "recursive_ls"
    _parameter_checks = {"forgetting": [Number(0.0, 1.0, closed="right")]}

    def __init__(self, *, forgetting=1.0):
        self.forgetting = forgetting

    def __sklearn_is_fitted__(self) -> bool:
        return hasattr(self, "state_")

    def export_sections(self) -> description.Sections:
        """The ``model`` and ``solver`` sections of its
        exported document (:mod:`svrqp.description`)."""
        return description.Sections(
            description.linear_model(self.coef_, float(self.state_.a[0]), True,
                                     forgetting=float(self.forgetting),
                                     n_samples_seen=int(self.n_samples_seen_)),
            description.least_squares_solver(RECURSION, {"forgetting": self.forgetting},
                                             {"sigma2": self.sigma2_}),
            centre=self.x_offset_)

    def fit(self, X: ArrayLike, y: ArrayLike) -> RecursiveLS:
        """Forget any previous state and run the recursion over the rows of (X, y) in order.

        Raises
        ------
        ProblemError
            Fewer samples than parameters, NaN.
        SingularSystemError
            The regressors never become linearly independent (constant or duplicated columns).
        """
        for name in ("state_", "n_features_in_", "feature_names_in_"):
            if hasattr(self, name):
                delattr(self, name)
        self.partial_fit(X, y)
        if not hasattr(self, "state_"):
            # No prefix determines the coefficients well: the batch solution of everything
            # either raises the precise error (rank deficiency, too few samples) or warns.
            X_pool, y_pool = self._pending
            self._start(X_pool, y_pool, len(y_pool))
        return self

    def partial_fit(self, X: ArrayLike, y: ArrayLike) -> RecursiveLS:
        """Absorb the rows of (X, y), in order, by the recursion.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,)
        """
        check_parameters(self, self._parameter_checks)
        first_call = not hasattr(self, "n_features_in_")
        if first_call:
            self.target_name_ = _target_name(y)
            self._pending = None
        X, y = _finite_training_data(self, X, y, reset=first_call)
        if hasattr(self, "state_"):
            self._set_state(recursive_ls.update_batch(self.state_, self._regressors(X), y))
            return self
        if self._pending is not None:
            X, y = np.vstack([self._pending[0], X]), np.concatenate([self._pending[1], y])
        start = recursive_ls.initial_prefix(_regressors(X, X[0]))
        if start is None:
            self._pending = (X, y)
            return self
        self._start(X, y, start)
        return self

    def _regressors(self, X: NDArray) -> NDArray:
        return _regressors(X, self.x_offset_)

    def _start(self, X: NDArray, y: NDArray, start: int) -> None:
        self.x_offset_ = X[0].copy()
        Z = self._regressors(X)
        names = ["intercept", *self._feature_names()]
        state = recursive_ls.batch_state(Z[:start], y[:start], forgetting=self.forgetting,
                                         column_names=names)
        self._set_state(recursive_ls.update_batch(state, Z[start:], y[start:]))
        self._pending = None

    def _set_state(self, state: recursive_ls.RecursiveLSState) -> None:
        self.state_ = state
        self.coef_ = state.a[1:].copy()
        self.intercept_ = float(state.a[0] - self.coef_ @ self.x_offset_)
        self.n_samples_seen_ = state.n_samples
        self.sigma2_ = state.sigma2 if state.weight > state.a.size else float("nan")

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Predict :math:`a_0 + X a` with the current coefficients, evaluated on the recursion's own
        regressors :math:`(1, x - x_\\mathrm{ref})` so that offset inputs keep their digits."""
        return self._regressors(_finite_inputs(self, X)) @ self.state_.a


def _regressors(X: NDArray, x_offset: NDArray) -> NDArray:
    """The recursion's regressors :math:`(1, x - x_\\mathrm{ref})`, one row per sample."""
    return np.column_stack([np.ones(len(X)), X - x_offset])


def merge_models(first: RecursiveLS, second: RecursiveLS) -> RecursiveLS:
    """The model of the union of two fitted models' data (S3 eqs. (20)–(24)).

    The second model's state is first expressed in the regressors of the first
    (:func:`svrqp.formulations.recursive_ls.transform_regressors`), then the two are merged.

    Raises
    ------
    ProblemError
        The models differ in features or forgetting factor.
    """
    for model in (first, second):
        check_is_fitted(model)
    if first._feature_names() != second._feature_names():
        raise ProblemError(
            f"cannot merge models on different features: {first._feature_names()} vs "
            f"{second._feature_names()}"
        )
    # (1, x − o₁) = T (1, x − o₂) with T = [[1, 0], [o₂ − o₁, I]].
    p = first.n_features_in_ + 1
    T = np.eye(p)
    T[1:, 0] = second.x_offset_ - first.x_offset_
    state = recursive_ls.merge(first.state_,
                               recursive_ls.transform_regressors(second.state_, T))
    merged = clone(first)
    for name in ("n_features_in_", "feature_names_in_", "target_name_", "x_offset_"):
        if hasattr(first, name):
            setattr(merged, name, getattr(first, name))
    merged._pending = None
    merged._set_state(state)
    return merged
