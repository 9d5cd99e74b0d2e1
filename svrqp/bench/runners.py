"""The per-method runners, the method registry, and
a run in a child process killed at its time limit.

A *method* is a (problem, formulation, backend) triple — e.g. the ε-SVR dual in split form
solved by Clarabel, or libsvm's SMO through :class:`sklearn.svm.SVR`. Each runner builds the
method's problem for a :class:`~svrqp.bench.cases.BenchCase`, solves it and returns a
:class:`~svrqp.bench.outcomes.RunOutcome`; :func:`run_isolated` runs it in a child process.
"""

from __future__ import annotations

import math
import multiprocessing
import time
import traceback
from collections.abc import Callable, Sequence

import numpy as np

from svrqp.bench.cases import BenchCase, Profile
from svrqp.bench.outcomes import (
    Method,
    QPPoint,
    RunOutcome,
    beta_certificates,
    ls_svr_outcome,
    qp_outcome,
    svr_outcome,
)
from svrqp.exceptions import ProblemError, SolverError
from svrqp.formulations import epsilon_svr, ls_svr
from svrqp.solvers.linear import solve_linear_system
from svrqp.solvers.qp_backends import BACKENDS, solve_qp


def _run_qp(case: BenchCase, method: Method, profile: Profile) -> RunOutcome:
    start = time.perf_counter()
    if method.formulation == "primal":
        K = None
        problem = epsilon_svr.primal_linear(case.X, case.y, case.C, case.epsilon)
    else:
        K = case.gram()
        problem = epsilon_svr.build(method.formulation, case.y, case.C, case.epsilon, K=K)
    build = time.perf_counter() - start
    # check_tol = inf: the benchmark judges the certificates itself (and keeps inaccurate rows).
    solution = solve_qp(problem, method.backend, tol=profile.tol, check_tol=math.inf)
    total = time.perf_counter() - start
    notes = {key.lstrip("_"): float(value) for key, value in solution.settings.items()
             if key in ("_pd_regularisation", "_pd_objective_shift")}
    point = QPPoint(method.formulation, problem, solution.x, solution.y, solution.z, solution.z_box)
    return qp_outcome(case, point, solution.status, K, build_time_s=build + solution.build_time,
                      solve_time_s=solution.solve_time, total_time_s=total,
                      iterations=math.nan if solution.iterations is None else solution.iterations,
                      notes=notes)


def _run_libsvm(case: BenchCase, method: Method, profile: Profile) -> RunOutcome:
    from sklearn.svm import SVR

    model = SVR(kernel=case.kernel, C=case.C, epsilon=case.epsilon, gamma=case.gamma,
                degree=case.degree, coef0=case.coef0, tol=profile.tol, cache_size=1000, max_iter=-1)
    start = time.perf_counter()
    model.fit(case.X, case.y)
    total = time.perf_counter() - start
    beta = np.zeros(case.n)
    beta[model.support_] = model.dual_coef_[0]
    # libsvm stops on its own at tol; it has no "unsolved" status other than hitting max_iter.
    status = "optimal" if model.fit_status_ == 0 else "max_iter"
    return svr_outcome(case, beta, float(model.intercept_[0]), case.kernel_times(beta), None,
                       status=status, build_time_s=0.0, solve_time_s=total, total_time_s=total,
                       iterations=float(np.sum(model.n_iter_)))


#: Relative trace error of the pivoted Cholesky factor
#: used by the low-rank methods, and its largest rank (·n).
LOW_RANK_TOL = 1e-6
LOW_RANK_MAX_FRACTION = 0.25


def _run_dual_ipm(case: BenchCase, method: Method, profile: Profile) -> RunOutcome:
    """svrqp's structure-exploiting interior point
    (:mod:`svrqp.solvers.dual_ipm`): dense, auto, or low-rank only."""
    from svrqp.linalg.kernel_columns import KernelColumns
    from svrqp.linalg.pivoted_cholesky import pivoted_cholesky
    from svrqp.solvers import dual_ipm

    parameters = {"kernel": case.kernel, "gamma": case.gamma, "degree": case.degree,
                  "coef0": case.coef0}
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
                                  max_rank=max(1, int(LOW_RANK_MAX_FRACTION * case.n)),
                                  tol=LOW_RANK_TOL)
        build = time.perf_counter() - start
        fit = dual_ipm.interior_point(dual_ipm.FactoredKernel(factor.L), case.y, case.C,
                                      case.epsilon, tol=profile.tol)
        beta, b, solved = fit.beta, fit.intercept, fit.converged
        approximation = factor.relative_trace_error
        # Certified on the problem it solved (K = L L^T), like the factored QP; the exact objective
        # and predictions below show what the approximation cost.
        residuals = beta_certificates(factor.L @ (factor.L.T @ beta), b, case.y, beta, case.C,
                                      case.epsilon)
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
    from svrqp.linalg.kernel_columns import KernelColumns
    from svrqp.linalg.pivoted_cholesky import pivoted_cholesky

    start = time.perf_counter()
    columns = KernelColumns(case.X, kernel=case.kernel, gamma=case.gamma, degree=case.degree,
                            coef0=case.coef0)
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
                       total_time_s=total,
                       iterations=math.nan if solution.iterations is None else solution.iterations,
                       notes={"approximation_error": factor.relative_trace_error})


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
    return ls_svr_outcome(case, K, alpha, b, residual_rel, status="optimal", build_time_s=build,
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
                       f"{list(epsilon_svr.FORMULATIONS) + ['low_rank']}, backends: "
                       f"{sorted(BACKENDS)}; "
                       f"svrqp's own: dual_ipm/{'|'.join(DUAL_IPM_FORMULATIONS)}")


def methods(formulations: Sequence[str], backends: Sequence[str], kernel: str,
            ls_svr_methods: bool = False) -> list[Method]:
    """The applicable ε-SVR methods of formulation × backend, plus LS-SVR.

    QP backends pair with the QP formulations (``stacked``, ``split``, ``low_rank``, and ``primal``
    with the linear kernel); the backend ``dual_ipm`` pairs with ``dense``, ``auto`` and
    ``low_rank``. A name that pairs with nothing is an
    error. The reference methods are not part of this list.
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
    unused = ({*formulations} - {m.formulation for m in chosen}) | (
        {*backends} - {m.backend for m in chosen}
    )
    if unused:
        raise ProblemError(f"{sorted(unused)} pair with none of the given backends/formulations "
                           f"(QP backends: {sorted(BACKENDS)} with "
                           f"{list(epsilon_svr.FORMULATIONS) + ['low_rank']}; dual_ipm with "
                           f"{list(DUAL_IPM_FORMULATIONS)}; primal needs kernel='linear')")
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
            outcome = RunOutcome(status="crashed", error=f"child process exited with code "
                                                         f"{child.exitcode}")
    except EOFError:
        outcome = RunOutcome(status="crashed", error=f"child process exited with code "
                                                     f"{child.exitcode}")
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

