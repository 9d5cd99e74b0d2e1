r"""Solver comparison harness: every backend × formulation × dataset × n is one row.

A *method* is a (problem, formulation, backend) triple — e.g. the ε-SVR dual in split form
solved by Clarabel, or libsvm's SMO through :class:`sklearn.svm.SVR`. Each method runs in a
child process that is killed at the per-run time limit; a method that hit the limit at one n is
not tried at larger n. Each run gives a :class:`RunOutcome`; :func:`evaluate` turns it into a row
with the columns of :data:`ROW_COLUMNS`, comparing it with the reference run of its problem
(libsvm for ε-SVR, ``numpy.linalg.solve`` of S4 eq. (5) for LS-SVR).

**Success** means the method says it solved the problem *and* every relative certificate
(primal residual, dual residual, duality gap) is at most the profile's ``residual_tol``.
Certificates of a QP are those of :meth:`QuadraticProgram.kkt_residuals` at the backend's
primal–dual point. Methods that return only :math:`(\beta, b)` (libsvm, and the decomposition
and low-rank solvers) are certified on the stacked dual (see :mod:`svrqp.formulations.epsilon_svr`)
with multipliers reconstructed from the model (:func:`beta_certificates`):

.. math::

    \alpha = \max(-\beta, 0),\quad \alpha^* = \max(\beta, 0),\quad \lambda = b,\quad
    f = K\beta + b,\quad z_\alpha = f - y - \varepsilon,\quad z_{\alpha^*} = y - f - \varepsilon ,

which zeroes the stationarity residual by construction, so every departure from optimality
shows in the primal residual :math:`\max(|\mathbf 1^\top\beta|, (|\beta| - C)^+)` and the duality gap

.. math::

    r_g = \sum_t z_t^+ (C - x_t) + \sum_t z_t^- x_t ,
    \qquad x = [\alpha; \alpha^*],\ z = [z_\alpha; z_{\alpha^*}],

scaled like :meth:`QuadraticProgram.kkt_residuals` (``1 +`` the largest term).

Times are aggregated per method by the shifted geometric mean
:math:`\exp(\overline{\log(t + s)}) - s` with failed runs counted at the time limit
(qpbenchmark's convention).
"""

from __future__ import annotations

import math
import multiprocessing
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError, SolverError
from svrqp.formulations import epsilon_svr, epsilon_svr_certificate, ls_svr
from svrqp.kernels import gram
from svrqp.solvers.qp_backends import BACKENDS, solve_qp
from svrqp.solvers.linear import solve_linear_system


# --------------------------------------------------------------------------------------------
# Profiles, datasets, cases
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Profile:
    """An accuracy profile: the tolerance asked of every method, and the one its certificates must meet."""

    name: str
    tol: float
    residual_tol: float


PROFILES: dict[str, Profile] = {
    "default": Profile("default", tol=1e-8, residual_tol=1e-6),
    "high": Profile("high", tol=1e-10, residual_tol=1e-8),
    "low": Profile("low", tol=1e-5, residual_tol=1e-3),
}


def _standardised(X: NDArray[np.float64], y: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    return (X - X.mean(axis=0)) / X.std(axis=0), (y - y.mean()) / y.std()


def friedman1(n: int, d: int, seed: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Friedman #1 (:func:`sklearn.datasets.make_friedman1`, noise 1.0), X and y standardised.

    Noisy: most points end up as support vectors, the slow case for SMO solvers.
    """
    from sklearn.datasets import make_friedman1

    if d < 5:
        raise ProblemError(f"friedman1 needs d >= 5 features, got d={d}")
    X, y = make_friedman1(n_samples=n, n_features=d, noise=1.0, random_state=seed)
    return _standardised(X, y)


def thermal(n: int, d: int, seed: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r"""An S0-like thermal-error set: ``d`` temperatures (°C) and an axial error (μm), standardised.

    Sample times :math:`t` are uniform on 0–250 min; sensor :math:`k` warms up as
    :math:`T_k = 20 + a_k (1 - e^{-t/\tau_k})` with :math:`\tau_k` log-spaced over 20–120 min, plus
    0.05 °C noise; the error is :math:`\sum_k c_k (T_k - 20) + 0.05 (T_1 - 20)^2` plus 2 μm noise
    (about 0.1 std(y), so ε = 0.1 sits at the noise level as a tuned model would). Smooth, with a
    low numerical rank kernel: few free support vectors, most support vectors at the bound C.
    """
    rng = np.random.default_rng(seed)
    time_min = rng.uniform(0.0, 250.0, n)
    tau_min = np.geomspace(20.0, 120.0, d)
    rise_C = rng.uniform(4.0, 12.0, d)
    T_C = 20.0 + rise_C * (1.0 - np.exp(-time_min[:, None] / tau_min)) + rng.normal(0.0, 0.05, (n, d))
    weights_um_per_C = rng.uniform(-1.0, 4.0, d)
    error_um = (T_C - 20.0) @ weights_um_per_C + 0.05 * (T_C[:, 0] - 20.0) ** 2 + rng.normal(0.0, 2.0, n)
    return _standardised(T_C, error_um)


#: Generated datasets: name -> generator(n, d, seed).
GENERATORS: dict[str, Callable[[int, int, int], tuple[NDArray, NDArray]]] = {
    "friedman1": friedman1,
    "thermal": thermal,
}


@dataclass(frozen=True)
class BenchCase:
    """One dataset at one size, with the kernel and SVR parameters every method is given."""

    dataset: str
    X: NDArray[np.float64]
    y: NDArray[np.float64]
    kernel: str
    C: float
    epsilon: float
    gamma: float
    degree: int = 3
    coef0: float = 0.0

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.X.shape[0]

    @property
    def d(self) -> int:
        """Number of features."""
        return self.X.shape[1]

    def gram(self, rows: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """Kernel matrix between ``rows`` (default: every sample) and the training samples."""
        return gram(self.X if rows is None else rows, self.X, kernel=self.kernel, gamma=self.gamma,
                    degree=self.degree, coef0=self.coef0)

    def kernel_times(self, B: NDArray[np.float64], chunk: int = 2048) -> NDArray[np.float64]:
        """:math:`K B` in row blocks, so memory stays O(chunk · n) (n = 20000 would need 3.2 GB)."""
        return np.concatenate([self.gram(self.X[start:start + chunk]) @ B for start in range(0, self.n, chunk)])


def resolve_gamma(gamma: float | str, X: NDArray[np.float64]) -> float:
    """``gamma`` as a number; ``"scale"`` is scikit-learn's :math:`1 / (d\\,\\operatorname{Var} X)`."""
    if gamma == "scale":
        variance = float(X.var())
        return 1.0 / (X.shape[1] * variance) if variance > 0 else 1.0
    value = float(gamma)
    if not np.isfinite(value) or value <= 0:
        raise ProblemError(f"gamma must be 'scale' or a positive number, got {gamma!r}")
    return value


def make_case(dataset: str, n: int, d: int, *, kernel: str = "rbf", C: float = 10.0, epsilon: float = 0.1,
              gamma: float | str = "scale", seed: int = 0) -> BenchCase:
    """Generate ``dataset`` (a name of :data:`GENERATORS`) with ``n`` samples and ``d`` features."""
    if dataset not in GENERATORS:
        raise ProblemError(f"dataset must be one of {sorted(GENERATORS)}, got {dataset!r}")
    if n < 2:
        raise ProblemError(f"n must be at least 2, got {n}")
    X, y = GENERATORS[dataset](n, d, seed)
    return BenchCase(dataset, X, y, kernel, float(C), float(epsilon), resolve_gamma(gamma, X))


# --------------------------------------------------------------------------------------------
# Methods and their outcomes
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Method:
    """One way of solving one problem: ``problem`` is ``"epsilon_svr"`` or ``"ls_svr"``."""

    problem: str
    formulation: str
    backend: str

    @property
    def label(self) -> str:
        """Short name used in tables and plot legends."""
        return f"{self.backend}/{self.formulation}"


@dataclass
class RunOutcome:
    """What one run produced, before it is compared with the reference.

    ``residuals`` holds the relative certificates that apply to the problem (``primal_rel``,
    and for QPs ``dual_rel`` and ``gap_rel``); ``decision`` is the model's prediction on the
    training inputs; ``objective`` the problem's own objective at the returned coefficients
    (:func:`svrqp.formulations.epsilon_svr.dual_objective` for ε-SVR).
    """

    status: str
    build_time_s: float = math.nan
    solve_time_s: float = math.nan
    total_time_s: float = math.nan
    iterations: float = math.nan
    residuals: dict[str, float] = field(default_factory=dict)
    objective: float = math.nan
    decision: NDArray[np.float64] | None = None
    support: NDArray[np.bool_] | None = None
    notes: dict[str, float] = field(default_factory=dict)
    error: str = ""


def beta_certificates(Kbeta: NDArray[np.float64], b: float, y: NDArray[np.float64], beta: NDArray[np.float64],
                      C: float, epsilon: float) -> dict[str, float]:
    """Relative certificates of a model :math:`(\\beta, b)` on the stacked ε-SVR dual (module docstring).

    Parameters
    ----------
    Kbeta, b
        :math:`K\\beta` on the training inputs, and the intercept.
    y, beta, C, epsilon
        Targets, dual coefficients and SVR parameters.

    Returns
    -------
    dict
        ``primal_rel``, ``dual_rel`` (zero by construction) and ``gap_rel``, scaled as
        :meth:`QuadraticProgram.kkt_residuals` scales them.
    """
    # b enters through the decision values Kβ + b, so r rounds as in the recorded benchmark results
    point = epsilon_svr_certificate.multipliers(beta, 0.0, Kbeta + b, y, epsilon)
    x = np.concatenate([point.alpha, point.alpha_star])
    z_plus = np.maximum(point.z_box, 0.0)
    balance = float(abs(beta.sum()))
    primal = max(balance, float(np.max(np.maximum(x - C, 0.0), initial=0.0)))
    quadratic = float(beta @ Kbeta)  # x^T P x
    linear = float(epsilon * np.abs(beta).sum() - y @ beta)  # q^T x (alpha_i alpha*_i = 0 here)
    upper = C * float(z_plus.sum())  # ub^T z_box^+ (lb = 0 adds nothing)
    gap = quadratic + linear + upper
    return {
        "primal_rel": primal / (1.0 + max(float(np.max(x, initial=0.0)), balance, C)),
        "dual_rel": 0.0,
        "gap_rel": abs(gap) / (1.0 + max(abs(quadratic), abs(linear), upper)),
    }


def _relative(residuals: dict[str, float]) -> dict[str, float]:
    return {key: float(residuals[key]) for key in ("primal_rel", "dual_rel", "gap_rel") if key in residuals}


def svr_outcome(case: BenchCase, beta: NDArray[np.float64], b: float, Kbeta: NDArray[np.float64],
                residuals: dict[str, float] | None, **fields: Any) -> RunOutcome:
    """A :class:`RunOutcome` of an ε-SVR method from its model :math:`(\\beta, b)`.

    ``residuals`` are the method's own certificates (a QP's), or ``None`` to certify the model
    with :func:`beta_certificates`.
    """
    if residuals is None:
        residuals = beta_certificates(Kbeta, b, case.y, beta, case.C, case.epsilon)
    objective = float(0.5 * beta @ Kbeta - case.y @ beta + case.epsilon * np.abs(beta).sum())
    return RunOutcome(residuals=_relative(residuals), objective=objective, decision=Kbeta + b,
                      support=epsilon_svr.support_mask(beta, case.C), **fields)


def qp_outcome(case: BenchCase, formulation: str, problem, x, y, z, z_box, status: str,
               K: NDArray[np.float64] | None, **fields: Any) -> RunOutcome:
    """Outcome of a QP formulation: certificates of ``problem`` at ``(x, y, z, z_box)``, model read off ``x``.

    This is the row evaluator's entry for QP solutions, so any ``x`` (including a perturbed one)
    is judged by its own certificates.
    """
    residuals = problem.kkt_residuals(x, y, z, z_box)
    beta = epsilon_svr.beta_from_solution(formulation, case.n, x, z)
    if formulation == "primal":
        w, b = x[:case.d], float(x[case.d])
        Kbeta = case.X @ (case.X.T @ beta)
        # The model is w·x + b; its predictions are X w + b (equal to Kβ + b at the optimum).
        return replace(svr_outcome(case, beta, b, Kbeta, residuals, status=status, **fields),
                       decision=case.X @ w + b)
    Kbeta = K @ beta
    b = epsilon_svr.intercept_from_kkt(K, case.y, beta, case.C, case.epsilon)
    return svr_outcome(case, beta, b, Kbeta, residuals, status=status, **fields)


# --------------------------------------------------------------------------------------------
# Runners (each runs inside the child process)
# --------------------------------------------------------------------------------------------


def _run_qp(case: BenchCase, method: Method, profile: Profile) -> RunOutcome:
    start = time.perf_counter()
    if method.formulation == "primal":
        K = None
        problem = epsilon_svr.primal_linear(case.X, case.y, case.C, case.epsilon)
    else:
        K = case.gram()
        problem = epsilon_svr.build(method.formulation, case.y, case.C, case.epsilon, K=K)
    build = time.perf_counter() - start
    # check_tol = inf: the harness judges the certificates itself (and keeps inaccurate rows).
    solution = solve_qp(problem, method.backend, tol=profile.tol, check_tol=math.inf)
    total = time.perf_counter() - start
    notes = {key.lstrip("_"): float(value) for key, value in solution.settings.items()
             if key in ("_pd_regularisation", "_pd_objective_shift")}
    return qp_outcome(case, method.formulation, problem, solution.x, solution.y, solution.z, solution.z_box,
                      solution.status, K, build_time_s=build + solution.build_time,
                      solve_time_s=solution.solve_time, total_time_s=total,
                      iterations=math.nan if solution.iterations is None else solution.iterations, notes=notes)


def _run_libsvm(case: BenchCase, method: Method, profile: Profile) -> RunOutcome:
    from sklearn.svm import SVR

    model = SVR(kernel=case.kernel, C=case.C, epsilon=case.epsilon, gamma=case.gamma, degree=case.degree,
                coef0=case.coef0, tol=profile.tol, cache_size=1000, max_iter=-1)
    start = time.perf_counter()
    model.fit(case.X, case.y)
    total = time.perf_counter() - start
    beta = np.zeros(case.n)
    beta[model.support_] = model.dual_coef_[0]
    # libsvm stops on its own at tol; it has no "unsolved" status other than hitting max_iter.
    status = "optimal" if model.fit_status_ == 0 else "max_iter"
    return svr_outcome(case, beta, float(model.intercept_[0]), case.kernel_times(beta), None, status=status,
                       build_time_s=0.0, solve_time_s=total, total_time_s=total,
                       iterations=float(np.sum(model.n_iter_)))


#: Relative trace error of the pivoted Cholesky factor used by the low-rank methods, and its largest rank (·n).
LOW_RANK_TOL = 1e-6
LOW_RANK_MAX_FRACTION = 0.25


def _run_dual_ipm(case: BenchCase, method: Method, profile: Profile) -> RunOutcome:
    """svrqp's structure-exploiting interior point (:mod:`svrqp.solvers.dual_ipm`): dense, auto, or low-rank only."""
    from svrqp.solvers import dual_ipm
    from svrqp.linalg.pivoted_cholesky import pivoted_cholesky
    from svrqp.linalg.kernel_columns import KernelColumns

    parameters = {"kernel": case.kernel, "gamma": case.gamma, "degree": case.degree, "coef0": case.coef0}
    start = time.perf_counter()
    K, approximation, residuals = None, 0.0, None
    if method.formulation == "dense":
        K = case.gram()
        build = time.perf_counter() - start
        fit = dual_ipm.solve_exact(K, case.y, case.C, case.epsilon, tol=profile.tol)
        beta, b, solved = fit.beta, fit.intercept, fit.crossover.exact or fit.ipm.converged
    elif method.formulation == "auto":
        build = 0.0
        fit = dual_ipm.solve_exact_from_data(case.X, case.y, case.C, case.epsilon, parameters,
                                             settings=dual_ipm.ExactSettings(tol=profile.tol))
        beta, b, solved = fit.beta, fit.intercept, fit.crossover.exact or fit.ipm.converged
    else:  # "low_rank": the factored problem only, an approximation whose error is reported
        factor = pivoted_cholesky(KernelColumns(case.X, **parameters),
                                  max_rank=max(1, int(LOW_RANK_MAX_FRACTION * case.n)), tol=LOW_RANK_TOL)
        build = time.perf_counter() - start
        fit = dual_ipm.interior_point(dual_ipm.FactoredKernel(factor.L), case.y, case.C, case.epsilon,
                                      tol=profile.tol)
        beta, b, solved = fit.beta, fit.intercept, fit.converged
        approximation = factor.relative_trace_error
        # Certified on the problem it solved (K = L L^T), like the factored QP; the exact objective
        # and predictions below show what the approximation cost.
        residuals = beta_certificates(factor.L @ (factor.L.T @ beta), b, case.y, beta, case.C, case.epsilon)
    total = time.perf_counter() - start
    iterations = fit.ipm.iterations if hasattr(fit, "ipm") else fit.iterations
    Kbeta = K @ beta if K is not None else case.kernel_times(beta)
    return svr_outcome(case, beta, b, Kbeta, residuals, status="optimal" if solved else "max_iter",
                       build_time_s=build, solve_time_s=total - build, total_time_s=total,
                       iterations=iterations, notes={"approximation_error": approximation})


def _run_low_rank_qp(case: BenchCase, method: Method, profile: Profile) -> RunOutcome:
    """The factored dual of :mod:`svrqp.formulations.low_rank` as an explicit QP for any backend."""
    from scipy.sparse.linalg import LinearOperator

    from svrqp.formulations import low_rank
    from svrqp.linalg.pivoted_cholesky import pivoted_cholesky
    from svrqp.linalg.kernel_columns import KernelColumns

    start = time.perf_counter()
    columns = KernelColumns(case.X, kernel=case.kernel, gamma=case.gamma, degree=case.degree, coef0=case.coef0)
    factor = pivoted_cholesky(columns, max_rank=max(1, int(LOW_RANK_MAX_FRACTION * case.n)),
                                       tol=LOW_RANK_TOL)
    problem = low_rank.dual_low_rank(factor.L, case.y, case.C, case.epsilon)
    build = time.perf_counter() - start
    solution = solve_qp(problem, method.backend, tol=profile.tol, check_tol=math.inf)
    beta = low_rank.beta_from_solution(case.n, solution.x)
    L = factor.L
    factored_K = LinearOperator((case.n, case.n), matvec=lambda v: L @ (L.T @ v), dtype=float)
    b = epsilon_svr.intercept_from_kkt(factored_K, case.y, beta, case.C, case.epsilon)
    total = time.perf_counter() - start
    residuals = problem.kkt_residuals(solution.x, solution.y, solution.z, solution.z_box)
    return svr_outcome(case, beta, b, case.kernel_times(beta), residuals, status=solution.status,
                       build_time_s=build + solution.build_time, solve_time_s=solution.solve_time,
                       total_time_s=total, iterations=math.nan if solution.iterations is None else solution.iterations,
                       notes={"approximation_error": factor.relative_trace_error})


def _ls_svr_outcome(case: BenchCase, K: NDArray[np.float64], alpha: NDArray[np.float64], b: float,
                    residual_rel: float, **fields: Any) -> RunOutcome:
    r"""LS-SVR: objective :math:`\tfrac12\alpha^\top(K + I/C)\alpha - y^\top\alpha` (the minimised dual)."""
    Kalpha = K @ alpha
    objective = float(0.5 * alpha @ Kalpha + 0.5 * alpha @ alpha / case.C - case.y @ alpha)
    return RunOutcome(residuals={"primal_rel": float(residual_rel)}, objective=objective, decision=Kalpha + b,
                      support=np.ones(case.n, dtype=bool), **fields)


def _run_ls_svr(case: BenchCase, method: Method, profile: Profile) -> RunOutcome:
    start = time.perf_counter()
    K = case.gram()
    if method.backend == "cholesky":
        build = time.perf_counter() - start
        alpha, b, solution = ls_svr.solve_cholesky_schur(K, case.y, case.C)
        residual_rel = solution.residuals["primal_rel"]
    else:
        system = ls_svr.kkt_system(K, case.y, case.C)
        build = time.perf_counter() - start
        if method.backend == "lu":
            solution = solve_linear_system(system, check_tol=math.inf)
            x, residual_rel = solution.x, solution.residuals["primal_rel"]
        else:  # the reference: numpy's LAPACK gesv, independent of scipy
            x = np.linalg.solve(system.M, system.rhs)
            residual_rel = system.residual(x)["residual_rel"]
        alpha, b = x[1:], float(x[0])
    total = time.perf_counter() - start
    return _ls_svr_outcome(case, K, alpha, b, residual_rel, status="optimal", build_time_s=build,
                           solve_time_s=total - build, total_time_s=total)


#: The reference method of each problem.
REFERENCES = {
    "epsilon_svr": Method("epsilon_svr", "smo", "libsvm"),
    "ls_svr": Method("ls_svr", "kkt", "numpy"),
}

#: Formulations of svrqp's interior point: exact dense, exact with a low-rank start, low-rank only.
DUAL_IPM_FORMULATIONS = ("dense", "auto", "low_rank")

LS_SVR_METHODS = (Method("ls_svr", "kkt", "lu"), Method("ls_svr", "cholesky_schur", "cholesky"))


def runner_for(method: Method) -> Callable[[BenchCase, Method, Profile], RunOutcome]:
    """The function that runs ``method`` (raises :class:`ProblemError` for an unknown one)."""
    if method.problem == "ls_svr":
        if method in LS_SVR_METHODS or method == REFERENCES["ls_svr"]:
            return _run_ls_svr
    elif method.problem == "epsilon_svr":
        if method == REFERENCES["epsilon_svr"]:
            return _run_libsvm
        if method.backend == "dual_ipm" and method.formulation in DUAL_IPM_FORMULATIONS:
            return _run_dual_ipm
        if method.formulation == "low_rank" and method.backend in BACKENDS:
            return _run_low_rank_qp
        if method.formulation in epsilon_svr.FORMULATIONS and method.backend in BACKENDS:
            return _run_qp
    raise ProblemError(f"no runner for {method}; ε-SVR formulations: "
                       f"{list(epsilon_svr.FORMULATIONS) + ['low_rank']}, backends: {sorted(BACKENDS)}; "
                       f"svrqp's own: dual_ipm/{'|'.join(DUAL_IPM_FORMULATIONS)}")


def methods(formulations: Sequence[str], backends: Sequence[str], kernel: str,
            ls_svr_methods: bool = False) -> list[Method]:
    """The applicable ε-SVR methods of formulation × backend, plus LS-SVR.

    QP backends pair with the QP formulations (``stacked``, ``split``, ``low_rank``, and ``primal``
    with the linear kernel); the backend ``dual_ipm`` pairs with ``dense``, ``auto`` and ``low_rank``.
    A name that pairs with nothing is an error. The reference methods are not part of this list.
    """
    chosen = []
    for formulation in formulations:
        for backend in backends:
            method = Method("epsilon_svr", formulation, backend)
            if formulation == "primal" and kernel != "linear":
                continue
            try:
                runner_for(method)
            except ProblemError:
                continue
            chosen.append(method)
    unused = ({*formulations} - {m.formulation for m in chosen}) | ({*backends} - {m.backend for m in chosen})
    if unused:
        raise ProblemError(f"{sorted(unused)} pair with none of the given backends/formulations "
                           f"(QP backends: {sorted(BACKENDS)} with {list(epsilon_svr.FORMULATIONS) + ['low_rank']}; "
                           f"dual_ipm with {list(DUAL_IPM_FORMULATIONS)}; primal needs kernel='linear')")
    return chosen + (list(LS_SVR_METHODS) if ls_svr_methods else [])


def run_isolated(case: BenchCase, method: Method, profile: Profile, time_limit_s: float,
                 threads: int = 1) -> RunOutcome:
    """Run ``method`` on ``case`` in a child process killed after ``time_limit_s`` seconds.

    The child limits BLAS/OpenMP to ``threads`` threads (threadpoolctl): on a shared machine a
    multi-threaded BLAS that competes for busy cores can be a hundred times slower than one thread.
    Never raises for a solver's failure: a :class:`SolverError` gives its status, any other
    exception ``"error"`` with its message, a killed child ``"time_limit"``, a crashed one
    ``"crashed"``.
    """
    runner = runner_for(method)
    context = multiprocessing.get_context("fork")
    receiver, sender = context.Pipe(duplex=False)
    child = context.Process(target=_child, args=(sender, runner, case, method, profile, threads),
                            daemon=True)
    child.start()
    sender.close()
    try:
        if receiver.poll(time_limit_s):
            outcome = receiver.recv()
        elif child.is_alive():
            outcome = RunOutcome(status="time_limit", total_time_s=time_limit_s,
                                 error=f"killed after the {time_limit_s:g} s time limit")
        else:
            outcome = RunOutcome(status="crashed", error=f"child process exited with code {child.exitcode}")
    except EOFError:
        outcome = RunOutcome(status="crashed", error=f"child process exited with code {child.exitcode}")
    finally:
        if child.is_alive():
            child.kill()
        child.join()
        receiver.close()
    return outcome


def _child(sender, runner, case: BenchCase, method: Method, profile: Profile, threads: int) -> None:
    from threadpoolctl import threadpool_limits

    try:
        with threadpool_limits(limits=threads):
            outcome = runner(case, method, profile)
    except SolverError as err:
        outcome = RunOutcome(status=err.status or "failed", error=str(err))
    except Exception as err:  # reported in the row: one bad backend must not stop the benchmark
        outcome = RunOutcome(status="error", error=f"{type(err).__name__}: {err} | "
                             + traceback.format_exc(limit=-2).replace("\n", " ")[-300:])
    sender.send(outcome)
    sender.close()


# --------------------------------------------------------------------------------------------
# Rows, success, aggregation
# --------------------------------------------------------------------------------------------

#: Every column of a result row, in order.
ROW_COLUMNS = (
    "dataset", "n", "d", "kernel", "C", "epsilon", "gamma", "problem", "formulation", "backend", "method",
    "profile", "tol", "residual_tol", "status", "success", "build_time_s", "solve_time_s", "total_time_s",
    "iterations", "primal_residual", "dual_residual", "duality_gap", "objective", "reference_objective",
    "objective_gap_rel", "prediction_diff_rel", "support_agreement", "n_support", "n_support_reference",
    "pd_regularisation", "pd_objective_shift", "approximation_error", "error",
)


def is_success(outcome: RunOutcome, profile: Profile) -> bool:
    """Solved, and every certificate that applies is finite and at most ``profile.residual_tol``."""
    return (
        outcome.status == "optimal"
        and bool(outcome.residuals)
        and all(math.isfinite(value) and value <= profile.residual_tol for value in outcome.residuals.values())
    )


def _jaccard(a: NDArray[np.bool_], b: NDArray[np.bool_]) -> float:
    union = int(np.sum(a | b))
    return 1.0 if union == 0 else float(np.sum(a & b)) / union


def evaluate(outcome: RunOutcome, method: Method, case: BenchCase, reference: RunOutcome | None,
             profile: Profile) -> dict[str, Any]:
    """One result row (keys :data:`ROW_COLUMNS`).

    Comparisons with the reference: ``objective_gap_rel`` is
    :math:`(J - J_\\text{ref}) / |J_\\text{ref}|` (negative: lower than the reference),
    ``prediction_diff_rel`` is :math:`\\max_i |f(x_i) - f_\\text{ref}(x_i)| / \\operatorname{std}(y)`
    on the training inputs, ``support_agreement`` the Jaccard index of the two support sets
    (:func:`svrqp.formulations.epsilon_svr.support_mask`, threshold relative to C). They are NaN
    when either run has no model.
    """
    has_reference = reference is not None and reference.decision is not None and outcome.decision is not None
    compare = (lambda fn: fn()) if has_reference else (lambda fn: math.nan)
    residual = outcome.residuals.get
    return {
        "dataset": case.dataset, "n": case.n, "d": case.d, "kernel": case.kernel, "C": case.C,
        "epsilon": case.epsilon, "gamma": case.gamma, "problem": method.problem,
        "formulation": method.formulation, "backend": method.backend, "method": method.label,
        "profile": profile.name, "tol": profile.tol, "residual_tol": profile.residual_tol,
        "status": outcome.status, "success": is_success(outcome, profile),
        "build_time_s": outcome.build_time_s, "solve_time_s": outcome.solve_time_s,
        "total_time_s": outcome.total_time_s, "iterations": outcome.iterations,
        "primal_residual": residual("primal_rel", math.nan), "dual_residual": residual("dual_rel", math.nan),
        "duality_gap": residual("gap_rel", math.nan), "objective": outcome.objective,
        "reference_objective": reference.objective if reference is not None else math.nan,
        "objective_gap_rel": compare(
            lambda: (outcome.objective - reference.objective) / (abs(reference.objective) or 1.0)),
        "prediction_diff_rel": compare(
            lambda: float(np.max(np.abs(outcome.decision - reference.decision)) / np.std(case.y))),
        "support_agreement": compare(lambda: _jaccard(outcome.support, reference.support)),
        "n_support": int(outcome.support.sum()) if outcome.support is not None else -1,
        "n_support_reference": (int(reference.support.sum())
                                if reference is not None and reference.support is not None else -1),
        "pd_regularisation": outcome.notes.get("pd_regularisation", 0.0),
        "pd_objective_shift": outcome.notes.get("pd_objective_shift", 0.0),
        "approximation_error": outcome.notes.get("approximation_error", 0.0),
        "error": outcome.error,
    }


def shifted_geometric_mean(times_s: Sequence[float], shift_s: float = 1.0) -> float:
    """:math:`\\exp(\\overline{\\log(t + s)}) - s`: small times count, one slow run does not dominate."""
    times = np.asarray(times_s, dtype=float)
    if times.size == 0:
        return math.nan
    return float(np.exp(np.mean(np.log(times + shift_s))) - shift_s)


def aggregate(rows: pd.DataFrame, time_limit_s: float, shift_s: float = 1.0) -> pd.DataFrame:
    """Per method: runs, successes, and the shifted geometric mean of total time (failures at the limit).

    ``sgm_ratio`` divides each method's mean by the smallest one (1.0 is the fastest).
    """
    times = rows["total_time_s"].where(rows["success"], time_limit_s)
    table = (
        rows.assign(charged_time_s=times)
        .groupby(["problem", "method"], sort=False)
        .agg(runs=("success", "size"), successes=("success", "sum"),
             sgm_time_s=("charged_time_s", lambda t: shifted_geometric_mean(t, shift_s)))
        .reset_index()
    )
    table["success_rate"] = table["successes"] / table["runs"]
    table["sgm_ratio"] = table["sgm_time_s"] / table.groupby("problem")["sgm_time_s"].transform("min")
    return table.sort_values(["problem", "sgm_time_s"]).reset_index(drop=True)


def ratios_to_reference(rows: pd.DataFrame, objective_gap_max: float = 1e-8,
                        prediction_diff_max: float = 1e-4) -> pd.DataFrame:
    """Per dataset and n: the reference's time, the fastest *exact* compared method, and their ratio.

    Exact means: success, objective at most ``objective_gap_max`` (relative) above the reference's,
    and predictions within ``prediction_diff_max``·std(y) of the reference's (the issue's targets).
    """
    reference = rows[rows["method"].isin([method.label for method in REFERENCES.values()])]
    exact = rows[rows["success"] & (rows["objective_gap_rel"] <= objective_gap_max)
                 & (rows["prediction_diff_rel"] <= prediction_diff_max)]
    table = []
    for (problem, dataset, n), runs in exact.groupby(["problem", "dataset", "n"], sort=True):
        ref = reference[(reference["problem"] == problem) & (reference["dataset"] == dataset) & (reference["n"] == n)]
        best = runs.loc[runs["total_time_s"].idxmin()]
        ref_time = float(ref["total_time_s"].iloc[0]) if len(ref) else math.nan
        table.append({"problem": problem, "dataset": dataset, "n": n, "reference": ref["method"].iloc[0] if len(ref) else "",
                      "reference_time_s": ref_time, "fastest_exact": best["method"],
                      "fastest_exact_time_s": best["total_time_s"], "ratio": best["total_time_s"] / ref_time})
    return pd.DataFrame(table, columns=["problem", "dataset", "n", "reference", "reference_time_s", "fastest_exact",
                                        "fastest_exact_time_s", "ratio"])


# --------------------------------------------------------------------------------------------
# The whole benchmark
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BenchConfig:
    """What to run: datasets × sizes, and the methods compared on each."""

    datasets: tuple[str, ...] = ("friedman1",)
    sizes: tuple[int, ...] = (250, 500, 1000)
    d: int = 10
    kernel: str = "rbf"
    C: float = 10.0
    epsilon: float = 0.1
    gamma: float | str = "scale"
    formulations: tuple[str, ...] = ("stacked", "split")
    backends: tuple[str, ...] = ("clarabel", "osqp", "piqp", "proxqp", "highs")
    ls_svr: bool = False
    profile: str = "default"
    time_limit_s: float = 60.0
    shift_s: float = 1.0
    threads: int = 1
    seed: int = 0

    def __post_init__(self) -> None:
        if self.profile not in PROFILES:
            raise ProblemError(f"profile must be one of {sorted(PROFILES)}, got {self.profile!r}")
        if not self.sizes or min(self.sizes) < 2:
            raise ProblemError(f"sizes must be integers >= 2, got {self.sizes}")
        if not (self.time_limit_s > 0):
            raise ProblemError(f"time_limit_s must be positive, got {self.time_limit_s}")
        if self.threads < 1:
            raise ProblemError(f"threads must be at least 1, got {self.threads}")

    def methods(self) -> list[Method]:
        """Every compared method, references first."""
        compared = methods(self.formulations, self.backends, self.kernel, self.ls_svr)
        references = [REFERENCES["epsilon_svr"]] + ([REFERENCES["ls_svr"]] if self.ls_svr else [])
        return references + compared

    def n_runs(self) -> int:
        """Number of rows the benchmark will produce."""
        return len(self.datasets) * len(self.sizes) * len(self.methods())


def import_backends(methods_: Sequence[Method]) -> None:
    """Import every package the methods use, once, so forked children do not pay the import."""
    import importlib

    import qpsolvers  # noqa: F401
    import sklearn.svm  # noqa: F401

    for backend in {method.backend for method in methods_} & set(BACKENDS):
        importlib.import_module(BACKENDS[backend].package)


def run_benchmark(config: BenchConfig, on_run: Callable[[str], None] | None = None) -> pd.DataFrame:
    """Run every method on every dataset and size (ascending n) and return the tidy table of rows.

    ``on_run(description)`` is called after each run (for a progress bar). A method that hit
    the time limit on a dataset is marked ``"skipped"`` at every larger n of that dataset.
    """
    profile = PROFILES[config.profile]
    all_methods = config.methods()
    import_backends(all_methods)
    rows = []
    for dataset in config.datasets:
        timed_out: set[Method] = set()
        for n in sorted(config.sizes):
            case = make_case(dataset, n, config.d, kernel=config.kernel, C=config.C, epsilon=config.epsilon,
                             gamma=config.gamma, seed=config.seed)
            references: dict[str, RunOutcome] = {}
            for method in all_methods:
                if method in timed_out:
                    outcome = RunOutcome(status="skipped", total_time_s=config.time_limit_s,
                                         error="hit the time limit at a smaller n")
                else:
                    outcome = run_isolated(case, method, profile, config.time_limit_s, config.threads)
                if outcome.status == "time_limit":
                    timed_out.add(method)
                if method == REFERENCES[method.problem]:
                    references[method.problem] = outcome  # its own row compares with nothing
                    rows.append(evaluate(outcome, method, case, None, profile))
                else:
                    rows.append(evaluate(outcome, method, case, references.get(method.problem), profile))
                if on_run is not None:
                    on_run(f"{dataset} n={n} {method.label}: {outcome.status}")
    return pd.DataFrame(rows, columns=list(ROW_COLUMNS))
