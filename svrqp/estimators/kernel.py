"""scikit-learn regressors over the explicit formulations: :class:`EpsilonSVR` and :class:`LSSVR`.

The estimators are thin: ``fit`` hands the data to one solve path and reads the model off its
certificate-checked result (kept as ``solution_``, the QP as ``problem_``): the paths of
:mod:`svrqp.solvers.auto`, :func:`svrqp.solvers.dual_qp.solve_dual` (a stock QP backend),
:func:`svrqp.solvers.dual_ipm.certified.solve_dual_ipm` (the structure-exploiting interior point
and exact crossover), :func:`svrqp.solvers.qp_backends.solve_qp` on the linear primal, and
LS-SVR's Cholesky or LU. Every ε-SVR answer is certified on the stated QP: the multipliers of
that QP are read off the optimality conditions
(:func:`svrqp.formulations.epsilon_svr_certificate.multipliers`) and its residuals are checked
like any backend's. Coefficients follow scikit-learn's conventions: ``dual_coef_`` holds
:math:`\\beta_i = \\alpha_i^* - \\alpha_i` of the support vectors and the prediction is
``gram(X, support_vectors_) @ dual_coef_[0] + intercept_[0]``.
"""

from __future__ import annotations

import dataclasses
from functools import partial

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from svrqp.estimators.fitted_state import CompactFitMixin, CompactSystemMixin
from svrqp.exceptions import ProblemError, SolverError, input_errors_as_problem_errors
from svrqp.export import describe
from svrqp.export.mixin import ExportMixin
from svrqp.formulations import epsilon_svr, epsilon_svr_certificate, ls_svr
from svrqp.kernels import MAX_DEGREE, check_kernel_range, gram
from svrqp.parameters import Boolean, Nothing, Number, OneOf, check_parameters
from svrqp.problems import check_psd
from svrqp.solution import Solution, require_certificates
from svrqp.solvers import dual_ipm, dual_qp
from svrqp.solvers.auto import AUTO, SMO_CROSSOVER, solve_auto, solve_path
from svrqp.solvers.dual_ipm.certified import DUAL_FORMULATIONS, DUAL_IPM, solve_dual_ipm
from svrqp.solvers.dual_qp import DualSettings
from svrqp.solvers.linear import solve_linear_system
from svrqp.solvers.qp_backends import BACKENDS, solve_qp
from svrqp.table_checks import check_magnitude, check_numeric_array

#: Every value ``EpsilonSVR.solver`` accepts: the automatic choice, svrqp's exact paths and the QP backends.
SOLVERS: tuple[str, ...] = (AUTO, SMO_CROSSOVER, DUAL_IPM, *BACKENDS)
#: ``solver="auto"`` on the linear primal QP (a sparse QP with no kernel matrix: a stock backend).
PRIMAL_AUTO_BACKEND = "clarabel"
#: Where a failed ``dual_ipm`` fit falls back to (a failed QP backend falls back to ``dual_ipm``).
FALLBACK_SOLVER = "clarabel"

#: What the kernel parameters of both models accept (:mod:`svrqp.parameters`).
_KERNEL_CHECKS = {
    "kernel": [OneOf(frozenset({"linear", "poly", "rbf", "precomputed"}))],
    "gamma": [OneOf(frozenset({"scale", "auto"})), Number(0.0)],
    "degree": [Number(1, MAX_DEGREE, closed="both", integer=True)],
    "coef0": [Number()],
}


class _KernelModel(RegressorMixin, BaseEstimator):
    """Shared kernel handling: input validation, ``gamma`` resolution, Gram matrices, predict."""

    def _validated_training_data(self, X: ArrayLike, y: ArrayLike) -> tuple[NDArray, NDArray]:
        check_numeric_array(X, "X")
        check_numeric_array(y, "y")
        with input_errors_as_problem_errors():
            X, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64)
        y = y.astype(np.float64, copy=False)  # boolean or integer targets
        check_magnitude(X, "X")
        check_magnitude(y, "y")
        if X.shape[0] < 2:
            raise ProblemError(f"n_samples = {X.shape[0]}: at least 2 samples are needed to fit, got 1 sample")
        if self.kernel == "precomputed" and X.shape[0] != X.shape[1]:
            raise ProblemError(f"a precomputed kernel must be square (n_samples, n_samples), got {X.shape}")
        return X, y

    def _resolve_gamma(self, X: NDArray[np.float64]) -> float:
        # Same rule as scikit-learn's SVR so that the cross-checks compare like with like.
        if self.gamma == "scale":
            variance = X.var()
            return 1.0 / (X.shape[1] * variance) if variance != 0 else 1.0
        if self.gamma == "auto":
            return 1.0 / X.shape[1]
        return float(self.gamma)

    def _training_gram(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        if self.kernel == "precomputed":
            check_psd(X, name="precomputed kernel X")
            return X
        K = gram(X, kernel=self.kernel, gamma=self.gamma_, degree=self.degree, coef0=self.coef0)
        if self.kernel == "poly" and self.coef0 < 0:
            check_psd(K, name="polynomial kernel with negative coef0")  # not PSD in general
        return K

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


class EpsilonSVR(CompactFitMixin, ExportMixin, _KernelModel):
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
        ``"smo_crossover"`` (:mod:`svrqp.solvers.warm_start`: a loose SMO run, then the exact active-set
        crossover), ``"dual_ipm"`` (:func:`svrqp.solvers.dual_ipm.exact.solve_exact`, an interior point on the
        reduced n×n system with the same crossover) or any backend of
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

    _export_kind = "epsilon_svr"
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

    def _export_sections(self) -> describe.Sections:
        return describe.kernel_sections(self, epsilon=self.epsilon, fit_intercept=True, requested_tol=self.tol)

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
            raise ProblemError(f"formulation='primal' needs kernel='linear', got kernel={self.kernel!r}")
        self.gamma_ = self._resolve_gamma(X)
        check_kernel_range(X, self.kernel, self.gamma_, self.degree, self.coef0)
        self.solver_, self.fallback_reason_ = self.solver, None
        try:
            beta, b = self._solve(X, y, self.solver, self.formulation)
        except SolverError as err:
            if not self.fallback:
                raise
            # A fit asked for with sound parameters must not fail because one solver did: the
            # other exact path, reported in solver_ and fallback_reason_ ("auto" on a dual has tried
            # dual_ipm already: its fallback is the rescaled QP backend).
            dual_auto = self.solver == AUTO and self.formulation != "primal"
            other = FALLBACK_SOLVER if self.solver == DUAL_IPM or dual_auto else DUAL_IPM
            formulation = self.formulation if self.formulation in DUAL_FORMULATIONS else "split"
            try:
                beta, b = self._solve(X, y, other, formulation)
            except SolverError as second:
                raise SolverError(f"{err}; the fallback {other!r} failed too: {second}",
                                  self.solver, err.status) from second
            self.solver_, self.fallback_reason_ = other, str(err)
            if self.formulation == "primal":
                self.coef_ = beta @ X
        if self.solver == AUTO and self.fallback_reason_ is None:
            self.solver_ = self.solution_.backend  # the path it chose
        support = beta != 0.0  # the certified coefficients are exactly zero off the support
        self.support_ = np.flatnonzero(support)
        self.support_vectors_ = X[support] if self.kernel != "precomputed" else np.empty((support.sum(), 0))
        self.dual_coef_ = beta[support][None, :]
        self.intercept_ = np.array([b])
        self._keep_fit_data(X, y, self.formulation)
        return self

    def _solve(self, X: NDArray[np.float64], y: NDArray[np.float64], solver: str,
               formulation: str) -> tuple[NDArray[np.float64], float]:
        """Certified (β, b) from one solver; sets ``problem_``, ``solution_`` and ``polished_``."""
        kernel_parameters = {"kernel": self.kernel, "gamma": self.gamma_, "degree": self.degree, "coef0": self.coef0}
        settings = DualSettings(formulation, self.tol, self.check_tol)
        if solver in (AUTO, SMO_CROSSOVER) and formulation != "primal":
            run = solve_auto if solver == AUTO else partial(solve_path, SMO_CROSSOVER)
            # the QP is never formed: problem_ is rebuilt on demand (svrqp.estimators.fitted_state)
            fit = run(self._training_gram(X) if self.kernel == "precomputed" else X, y, self.C, self.epsilon,
                      kernel_parameters=kernel_parameters, settings=settings)
        elif solver == DUAL_IPM:
            low_rank_possible = self.kernel in ("rbf", "poly")  # a linear K is degenerate, a precomputed one has no X
            fit = solve_dual_ipm(self._training_gram(X), y, self.C, self.epsilon, settings,
                                 X=X if low_rank_possible else None, kernel_parameters=kernel_parameters)
        elif formulation == "primal":
            if solver == SMO_CROSSOVER:
                raise ProblemError(f"solver={SMO_CROSSOVER!r} solves a kernel dual: formulation must be one of "
                                   f"{DUAL_FORMULATIONS}, got 'primal'")
            return self._solve_primal(X, y, PRIMAL_AUTO_BACKEND if solver == AUTO else solver)
        else:
            fit = dual_qp.solve_dual(self._training_gram(X), y, self.C, self.epsilon, solver, settings)
        _, _, self.problem_, self.solution_, self.polished_ = fit
        return fit.beta, fit.intercept

    def _solve_primal(self, X: NDArray[np.float64], y: NDArray[np.float64],
                      solver: str) -> tuple[NDArray[np.float64], float]:
        """The linear primal: β from the multipliers, rounded and certified like the duals'.

        The backend solves the primal for the targets of :class:`~svrqp.formulations.epsilon_svr.DualScaling`
        (:math:`\tilde y = (y - m)/a`, :math:`\tilde\varepsilon = \varepsilon/a`, :math:`\tilde C = C/a`);
        the primal variables and multipliers scale by a (b is shifted by m) back onto ``problem_``,
        where the certificates are checked.
        """
        C = float(self.C)
        self.problem_ = epsilon_svr.build("primal", y, C, self.epsilon, X=X)
        m, a, _ = scaling = epsilon_svr.DualScaling.of(y, C)
        record = solve_qp(epsilon_svr.build("primal", (y - m) / a, C / a, self.epsilon / a, X=X), solver,
                          tol=self.tol, check_tol=self.check_tol)
        x, z = a * record.x, a * record.z
        x[X.shape[1]] += m
        z_box = None if record.z_box is None else a * record.z_box
        self.solution_ = Solution.of_qp(self.problem_, (x, record.y, z, z_box), dataclasses.replace(
            record.record, settings={**record.settings, "scaling": scaling._asdict()}))
        require_certificates(self.solution_, self.problem_, record.settings["check_tol"])
        beta = epsilon_svr.beta_from_solution("primal", X.shape[0], self.solution_.x, self.solution_.z)
        # Multipliers are as accurate as the backend's tolerance: settle the active sets exactly
        # (K = X Xᵀ column by column), as polish and the crossover do for the duals.
        exact = dual_ipm.crossover(lambda idx: X @ X[idx].T, y, C, float(self.epsilon), beta,
                                   products=lambda idx, v: X @ (X[idx].T @ v))
        self.polished_ = exact.exact
        beta = epsilon_svr.returned_coefficients(exact.beta if exact.exact else beta, C)
        self.coef_ = self.solution_.x[:X.shape[1]].copy()
        K_beta = X @ (X.T @ beta)
        b = epsilon_svr.intercept_from_residual(y - K_beta, beta, C, self.epsilon)
        certificate = epsilon_svr_certificate.model_certificate(
            y, beta, K_beta, b, C, self.epsilon, float(np.max(np.einsum("ij,ij->i", X, X), initial=0.0)))
        self.solution_.residuals.update(certificate)
        epsilon_svr_certificate.require_model_certificate(certificate, self.solution_.settings["check_tol"], solver)
        return beta, b


class LSSVR(CompactSystemMixin, ExportMixin, _KernelModel):
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

    _export_kind = "ls_svr"
    _parameter_checks = {
        "C": [Number(0.0)],
        **_KERNEL_CHECKS,
        "fit_intercept": [Boolean()],
        "solver": [OneOf(frozenset({"cholesky", "lu"}))],
    }

    def __init__(self, *, C=1.0, kernel="rbf", gamma="scale", degree=3, coef0=0.0, fit_intercept=True,
                 solver="cholesky"):
        self.C = C
        self.kernel = kernel
        self.gamma = gamma
        self.degree = degree
        self.coef0 = coef0
        self.fit_intercept = fit_intercept
        self.solver = solver

    def _export_sections(self) -> describe.Sections:
        return describe.kernel_sections(self, epsilon=None, fit_intercept=self.fit_intercept, requested_tol=None)

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
        check_kernel_range(X, self.kernel, self.gamma_, self.degree, self.coef0)
        K = self._training_gram(X)
        self._keep_fit_data(K if self.kernel == "precomputed" else None, y)
        self.problem_ = ls_svr.kkt_system(K, y, self.C, self.fit_intercept) if self.solver == "lu" else None
        if self.solver == "lu":
            self.solution_ = solve_linear_system(self.problem_)
            x = self.solution_.x
            alpha, b = (x[1:], float(x[0])) if self.fit_intercept else (x, 0.0)
        else:
            # A Gram matrix of our own is not needed afterwards (problem_ is rebuilt from X on demand):
            # factor it in place; a precomputed kernel is the caller's array and is left alone.
            alpha, b, self.solution_ = ls_svr.solve_cholesky_schur(K, y, self.C, self.fit_intercept,
                                                                   overwrite_K=self.kernel != "precomputed")
        if not (np.all(np.isfinite(alpha)) and np.isfinite(b)):
            raise SolverError("LS-SVR system gave non-finite coefficients", self.solver, "failed")
        self.support_ = np.arange(X.shape[0])
        self.support_vectors_ = X if self.kernel != "precomputed" else np.empty((X.shape[0], 0))
        self.dual_coef_ = alpha[None, :]
        self.intercept_ = np.array([b])
        return self
