"""scikit-learn regressors over the explicit formulations: :class:`EpsilonSVR` and :class:`LSSVR`.

The estimators are thin: ``fit`` validates the data, hands it to one solve and reads the model
off its certificate-checked result (kept as ``solution_``, the QP as ``problem_``).
:class:`EpsilonSVR` asks :func:`svrqp.solvers.epsilon_svr.solve_epsilon_svr`, the one place that
picks the ε-SVR solver, falls back and certifies the answer on the stated QP; :class:`LSSVR`
solves its KKT system by Cholesky (:func:`svrqp.formulations.ls_svr.solve_cholesky_schur`) or
LU. Coefficients follow scikit-learn's conventions: ``dual_coef_`` holds
:math:`\\beta_i = \\alpha_i^* - \\alpha_i` of the support vectors and the prediction is
``gram(X, support_vectors_) @ dual_coef_[0] + intercept_[0]``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from svrqp import description
from svrqp.estimators.fitted_state import CompactFitMixin, CompactSystemMixin
from svrqp.exceptions import ProblemError, SolverError, input_errors_as_problem_errors
from svrqp.formulations import epsilon_svr, ls_svr
from svrqp.kernels import MAX_DEGREE, check_kernel_range, gram, training_gram
from svrqp.parameters import Boolean, Nothing, Number, OneOf, check_parameters
from svrqp.solvers.epsilon_svr import SOLVERS, SolveOptions, SVRTask, solve_epsilon_svr
from svrqp.solvers.linear import solve_linear_system
from svrqp.table_checks import check_finite_magnitude, check_magnitude, check_numeric_array

#: What the kernel parameters of both models accept (:mod:`svrqp.parameters`).
_KERNEL_CHECKS = {
    "kernel": [OneOf(frozenset({"linear", "poly", "rbf", "precomputed"}))],
    "gamma": [OneOf(frozenset({"scale", "auto"})), Number(0.0)],
    "degree": [Number(1, MAX_DEGREE, closed="both", integer=True)],
    "coef0": [Number()],
}


def _finite_float_arrays(X: Any, y: Any) -> bool:
    """Whether ``X`` and ``y`` are float64 ndarrays (2-D, at least one row and column; 1-D of the
    same length) with finite values: scikit-learn's ``check_X_y`` returns such arrays unchanged,
    and its checks cost 20 times a 50-point libsvm run (0.6 ms against 0.05 ms, measured)."""
    return (type(X) is np.ndarray and type(y) is np.ndarray and X.dtype == np.float64
            and y.dtype == np.float64 and X.ndim == 2 and y.ndim == 1
            and X.shape[0] == y.shape[0] and min(X.shape) >= 1
            and bool(np.isfinite(X).all()) and bool(np.isfinite(y).all()))


class _KernelModel(RegressorMixin, BaseEstimator):
    """Shared kernel handling: input validation, ``gamma`` resolution, Gram matrices, predict."""

    def _validated_training_data(self, X: ArrayLike, y: ArrayLike) -> tuple[NDArray, NDArray]:
        if _finite_float_arrays(X, y):  # what check_X_y would return as is
            # validate_data's bookkeeping for an array without column names (its name lookup
            # through narwhals costs more than a 50-point libsvm run)
            self.n_features_in_ = X.shape[1]
            self.__dict__.pop("feature_names_in_", None)
            check_finite_magnitude(X, "X")
            check_finite_magnitude(y, "y")
            return self._checked_shape(X, y)
        check_numeric_array(X, "X")
        check_numeric_array(y, "y")
        with input_errors_as_problem_errors():
            X, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64)
        y = y.astype(np.float64, copy=False)  # boolean or integer targets
        check_magnitude(X, "X")
        check_magnitude(y, "y")
        return self._checked_shape(X, y)

    def _checked_shape(self, X: NDArray, y: NDArray) -> tuple[NDArray, NDArray]:
        if X.shape[0] < 2:
            raise ProblemError(f"n_samples = {X.shape[0]}: at least 2 samples are needed to fit, "
                               f"got 1 sample")
        if self.kernel == "precomputed" and X.shape[0] != X.shape[1]:
            raise ProblemError(f"a precomputed kernel must be square (n_samples, n_samples), got "
                               f"{X.shape}")
        return X, y

    def _resolve_gamma(self, X: NDArray[np.float64]) -> float:
        # Same rule as scikit-learn's SVR so that the cross-checks compare like with like.
        if self.gamma == "scale":
            variance = X.var()
            return 1.0 / (X.shape[1] * variance) if variance != 0 else 1.0
        if self.gamma == "auto":
            return 1.0 / X.shape[1]
        return float(self.gamma)

    def _kernel_parameters(self) -> dict[str, Any]:
        """``kernel``, the resolved ``gamma_``, ``degree`` and
        ``coef0``, as :func:`svrqp.kernels.gram` takes them."""
        return {"kernel": self.kernel, "gamma": self.gamma_, "degree": self.degree,
                "coef0": self.coef0}

    def _decision(self, X: ArrayLike) -> NDArray[np.float64]:
        check_is_fitted(self)
        check_numeric_array(X, "X")
        with input_errors_as_problem_errors():
            X = validate_data(self, X, reset=False, dtype=np.float64)
        check_magnitude(X, "X")
        if self.kernel == "precomputed":
            K = X[:, self.support_]
        else:
            K = gram(X, self.support_vectors_, kernel=self.kernel, gamma=self.gamma_,
                     degree=self.degree, coef0=self.coef0)
        return K @ self.dual_coef_[0] + self.intercept_[0]

    def predict(self, X: ArrayLike) -> NDArray[np.float64]:
        """Predict :math:`f(x) = \\sum_i \\beta_i k(x_i, x) + b`.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Inputs (for ``kernel="precomputed"``: the kernel between them and the training set).
        """
        return self._decision(X)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.pairwise = self.kernel == "precomputed"
        return tags


class EpsilonSVR(CompactFitMixin, _KernelModel):
    """ε-support vector regression solved as an explicit QP.

    Parameters
    ----------
    C : float, default=1.0
        Box bound on the dual variables (weight of the ε-insensitive loss).
    epsilon : float, default=0.1
        Half-width of the insensitive tube, in the units of ``y``.
    kernel : {"linear", "poly", "rbf", "precomputed"}, default="rbf"
    gamma : {"scale", "auto"} or float, default="scale"
        RBF/polynomial scale in scikit-learn's convention (see :mod:`svrqp.kernels`).
    degree : int, default=3
    coef0 : float, default=0.0
    solver : str, default="auto"
        ``"auto"`` (:mod:`svrqp.solvers.auto`: the fastest exact path for the problem, certified
        on the QP of ``formulation``; the choice is kept as ``solver_``),
        ``"smo_crossover"`` (:mod:`svrqp.solvers.warm_start`: a loose SMO run, then the exact
        active-set crossover), ``"dual_ipm"`` (:func:`svrqp.solvers.dual_ipm.exact.solve_exact`, an
        interior point on the reduced n×n system with the same crossover) or any backend of
        :data:`svrqp.solvers.qp_backends.BACKENDS` (the QP handed to a stock solver). With
        ``formulation="primal"``, ``"auto"`` hands the primal QP to Clarabel.
    formulation : {"split", "stacked", "primal"}, default="split"
        Which equivalent QP to solve (``"primal"`` needs ``kernel="linear"``). With
        ``solver="dual_ipm"``: the dual QP kept as ``problem_`` and whose residuals certify the
        solution (``"split"`` or ``"stacked"``; every kernel, linear included).
    tol : float, default=1e-8
        Requested solver accuracy.
    check_tol : float or None, default=None
        Largest relative primal residual, dual residual and duality gap accepted from the
        backend (``None``: 100·tol); a solution above it raises :class:`SolverError`. The same
        bound applies to the returned model's own certificate in the units of the data
        (:func:`svrqp.formulations.epsilon_svr_certificate.model_certificate`).
    fallback : bool, default=True
        When the chosen solver fails or misses a certificate, solve again with the other exact
        path (``"dual_ipm"`` for a QP backend, Clarabel for ``"dual_ipm"``) and say so in
        ``solver_`` and ``fallback_reason_``; ``False`` raises the solver's :class:`SolverError`.

    Attributes
    ----------
    support_ : ndarray of int
        Indices of the support vectors.
    support_vectors_ : ndarray of shape (n_SV, n_features)
    dual_coef_ : ndarray of shape (1, n_SV)
        :math:`\\beta_i = \\alpha_i^* - \\alpha_i` (scikit-learn's ``dual_coef_``).
    intercept_ : ndarray of shape (1,)
        Bias ``b`` recovered from the KKT conditions.
    gamma_ : float
        The ``gamma`` actually used.
    problem_ : QuadraticProgram
        The QP that was solved (rebuilt from the training data on first access when the path did
        not form it, and after unpickling: :mod:`svrqp.estimators.fitted_state`).
    solution_ : Solution
        The certificate-checked solution (after unpickling: the point, multipliers and
        certificates rebuilt at the returned coefficients).
    solver_ : str
        The solver whose answer the model is: ``solver``, the path ``"auto"`` chose (a key of
        :data:`svrqp.solvers.auto.PATHS`, or Clarabel on the primal), or the other exact path
        after a fallback.
    fallback_reason_ : str or None
        Why ``solver`` was not used (its error message), or ``None``.
    polished_ : bool
        Whether the active-set polish of :func:`svrqp.formulations.epsilon_svr.polish` replaced
        the solver's dual coefficients (dual formulations only); with ``solver="dual_ipm"``,
        whether its crossover reached the exact optimum.
    """

    export_kind = "epsilon_svr"
    _parameter_checks = {
        "C": [Number(0.0)],
        "epsilon": [Number(0.0, closed="left")],
        **_KERNEL_CHECKS,
        "solver": [OneOf(frozenset(SOLVERS))],
        "formulation": [OneOf(frozenset(epsilon_svr.FORMULATIONS))],
        "tol": [Number(0.0)],
        "check_tol": [Number(0.0), Nothing()],
        "fallback": [Boolean()],
    }

    def __init__(self, *, C=1.0, epsilon=0.1, kernel="rbf", gamma="scale", degree=3, coef0=0.0,
                 solver="auto", formulation="split", tol=1e-8, check_tol=None, fallback=True):
        self.C = C
        self.epsilon = epsilon
        self.kernel = kernel
        self.gamma = gamma
        self.degree = degree
        self.coef0 = coef0
        self.solver = solver
        self.formulation = formulation
        self.tol = tol
        self.check_tol = check_tol
        self.fallback = fallback

    def export_sections(self) -> description.Sections:
        """The ``model`` and ``solver`` sections of its
        exported document (:mod:`svrqp.description`)."""
        return description.kernel_sections(self, epsilon=self.epsilon, fit_intercept=True,
                                           requested_tol=self.tol)

    def fit(self, X: ArrayLike, y: ArrayLike) -> EpsilonSVR:
        """Build the ε-SVR QP for (X, y), solve it, and keep the support vectors.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,)
        """
        check_parameters(self, self._parameter_checks)
        X, y = self._validated_training_data(X, y)
        if self.formulation == "primal" and self.kernel != "linear":
            raise ProblemError(f"formulation='primal' needs kernel='linear', got "
                               f"kernel={self.kernel!r}")
        self.gamma_ = self._resolve_gamma(X)
        kernel_parameters = self._kernel_parameters()
        check_kernel_range(X, **kernel_parameters)
        fit = solve_epsilon_svr(X, y, SVRTask(self.C, self.epsilon, kernel_parameters),
                                SolveOptions(self.solver, self.formulation, self.tol,
                                             self.check_tol, self.fallback))
        self.problem_, self.solution_, self.polished_ = fit.problem, fit.solution, fit.polished
        self.solver_, self.fallback_reason_ = fit.solver, fit.fallback_reason
        if fit.coef is not None:
            self.coef_ = fit.coef
        support = fit.beta != 0.0  # the certified coefficients are exactly zero off the support
        self.support_ = support.nonzero()[0]
        self.support_vectors_ = (
            X[support] if self.kernel != "precomputed" else np.empty((support.sum(), 0))
        )
        self.dual_coef_ = fit.beta[support][None, :]
        self.intercept_ = np.array([fit.intercept])
        self._keep_fit_data(X, y, self.formulation)
        return self


class LSSVR(CompactSystemMixin, _KernelModel):
    """Least-squares SVR (S4): the KKT linear system, solved by Cholesky and a Schur complement.

    Parameters
    ----------
    C : float, default=1.0
        Weight of the squared errors (the system has :math:`I/C` on its diagonal).
    kernel, gamma, degree, coef0
        As for :class:`EpsilonSVR`.
    fit_intercept : bool, default=True
        Keep the bias row of the KKT system; without it the model is ``KernelRidge(alpha=1/C)``.
    solver : {"cholesky", "lu"}, default="cholesky"
        ``"cholesky"``: one Cholesky of :math:`\\Omega + I/C` and the Schur complement for b;
        ``"lu"``: LU of the full bordered system (the reference).

    Attributes
    ----------
    dual_coef_ : ndarray of shape (1, n_samples)
        :math:`\\alpha` (every training point is a support vector in LS-SVR).
    intercept_ : ndarray of shape (1,)
    support_, support_vectors_, gamma_, solution_
        As for :class:`EpsilonSVR`.
    problem_ : LinearSystem
        The full KKT system of S4 eq. (5) (solved by LU; the Cholesky path never forms it, and it is
        rebuilt on first access and after unpickling: :mod:`svrqp.estimators.fitted_state`).
    """

    export_kind = "ls_svr"
    _parameter_checks = {
        "C": [Number(0.0)],
        **_KERNEL_CHECKS,
        "fit_intercept": [Boolean()],
        "solver": [OneOf(frozenset({"cholesky", "lu"}))],
    }

    def __init__(self, *, C=1.0, kernel="rbf", gamma="scale", degree=3, coef0=0.0,
                 fit_intercept=True, solver="cholesky"):
        self.C = C
        self.kernel = kernel
        self.gamma = gamma
        self.degree = degree
        self.coef0 = coef0
        self.fit_intercept = fit_intercept
        self.solver = solver

    def export_sections(self) -> description.Sections:
        """The ``model`` and ``solver`` sections of its
        exported document (:mod:`svrqp.description`)."""
        return description.kernel_sections(self, epsilon=None, fit_intercept=self.fit_intercept,
                                           requested_tol=None)

    def fit(self, X: ArrayLike, y: ArrayLike) -> LSSVR:
        """Solve the LS-SVR KKT system for (X, y).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,)
        """
        check_parameters(self, self._parameter_checks)
        X, y = self._validated_training_data(X, y)
        self.gamma_ = self._resolve_gamma(X)
        kernel_parameters = self._kernel_parameters()
        check_kernel_range(X, **kernel_parameters)
        K = training_gram(X, kernel_parameters)
        self._keep_fit_data(K if self.kernel == "precomputed" else None, y)
        self.problem_ = ls_svr.kkt_system(K, y, self.C,
                                          self.fit_intercept) if self.solver == "lu" else None
        if self.solver == "lu":
            self.solution_ = solve_linear_system(self.problem_)
            x = self.solution_.x
            alpha, b = (x[1:], float(x[0])) if self.fit_intercept else (x, 0.0)
        else:
            # A Gram matrix of our own is not needed afterwards (problem_ is rebuilt from X on
            # demand): factor it in place; a precomputed
            # kernel is the caller's array and is left alone.
            alpha, b, self.solution_ = ls_svr.solve_cholesky_schur(
                K, y, self.C, self.fit_intercept, overwrite_K=self.kernel != "precomputed"
            )
        if not (np.all(np.isfinite(alpha)) and np.isfinite(b)):
            raise SolverError("LS-SVR system gave non-finite coefficients", self.solver, "failed")
        self.support_ = np.arange(X.shape[0])
        self.support_vectors_ = X if self.kernel != "precomputed" else np.empty((X.shape[0], 0))
        self.dual_coef_ = alpha[None, :]
        self.intercept_ = np.array([b])
        return self
