"""Quadratic programs through every installed backend:
``solve_qp(problem, backend=...) -> Solution``.

A QP goes to any installed `qpsolvers <https://qpsolvers.github.io>`_ backend or to cvxpy (the
same QP stated in cvxpy's modelling language). Every backend has one adapter entry in
:data:`BACKENDS`: the extra that installs it, the matrix format it prefers, how the common
tolerance ``tol`` maps onto its own settings, and the settings it accepts (anything else is
rejected with the valid list — no unchecked ``**kwargs``).

Every returned :class:`~svrqp.solution.Solution` has been certificate-checked: its relative
primal residual, dual residual and duality gap (see :meth:`QuadraticProgram.kkt_residuals`) are
at most ``check_tol``; otherwise :class:`~svrqp.exceptions.SolverError` names the backend and its
status.

Sign conventions follow qpsolvers: ``y`` multiplies :math:`Ax - b`, ``z \\ge 0`` multiplies
:math:`Gx - h`, and ``z_box`` is negative on active lower bounds, positive on active upper bounds.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import os
import time
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from svrqp.exceptions import BackendNotAvailableError, ProblemError, SolverError
from svrqp.problems import QuadraticProgram
from svrqp.solution import (
    Point,
    Solution,
    SolverRecord,
    check_limit,
    require_certificates,
)

#: Tiny diagonal added for backends that need a positive definite P (Goldfarb–Idnani in
#: quadprog): relative to max |P_ii|. Its effect on the objective is reported in ``settings``.
PD_REGULARISATION = 1e-8


#: Wall-clock budget of one backend call (seconds), passed to every backend that takes one
#: (clarabel, osqp, highs, scs); the others get an iteration limit (piqp, proxqp, daqp, cvxopt,
#: qpalm). A call that hits either ends in SolverError naming the backend ("time_limit" or
#: "max_iter"), never in a hang: HiGHS ran for minutes on a dual whose box is 1e13 wide.
TIME_LIMIT_S = 60.0
#: Iteration budget of the backends without a time limit, and of HiGHS's active-set QP besides
#: its time limit: on the 10-point dual of finding 14 (a box 1e13 wide) HiGHS cycled through a
#: million iterations in 3 s, where a sound dual of n points takes about 7n (measured at n = 100
#: and 400).
ITERATION_LIMIT = 100_000


@dataclass(frozen=True)
class Backend:
    """How svrqp talks to one backend."""

    name: str
    package: str
    extra: str | None
    sparse: bool
    tolerances: Callable[[float], dict[str, Any]]
    options: frozenset[str]
    needs_positive_definite: bool = False

    @property
    def install_hint(self) -> str:
        """What to install when this backend is missing."""
        if self.extra is None:
            return f"pip install {self.package}"
        return f"pip install 'svrqp[{self.extra}]'"


BACKENDS: dict[str, Backend] = {
    backend.name: backend
    for backend in (
        Backend(
            "clarabel", "clarabel", None, True,
            lambda tol: {"tol_gap_abs": tol, "tol_gap_rel": tol, "tol_feas": tol,
                         "tol_ktratio": 1e-2 * tol, "time_limit": TIME_LIMIT_S},
            frozenset({"max_iter", "time_limit", "tol_gap_abs", "tol_gap_rel", "tol_feas",
                       "tol_ktratio", "equilibrate_enable", "presolve_enable",
                       "direct_solve_method", "static_regularization_enable",
                       "iterative_refinement_enable"}),
        ),
        Backend(
            "osqp", "osqp", None, True,
            # ADMM reaches 1e-8 only with polishing and many iterations (measured on the primal).
            lambda tol: {"eps_abs": tol, "eps_rel": tol, "polishing": True,
                         "max_iter": ITERATION_LIMIT, "time_limit": TIME_LIMIT_S},
            frozenset({"max_iter", "eps_abs", "eps_rel", "polishing", "rho", "sigma", "alpha",
                       "adaptive_rho", "scaling", "time_limit", "check_termination",
                       "warm_starting", "eps_prim_inf", "eps_dual_inf", "polish_refine_iter"}),
        ),
        Backend(
            "piqp", "piqp", "solvers", False,
            lambda tol: {"eps_abs": tol, "eps_rel": tol, "max_iter": ITERATION_LIMIT},
            frozenset({"eps_abs", "eps_rel", "max_iter", "check_duality_gap", "eps_duality_gap_abs",
                       "eps_duality_gap_rel", "preconditioner_iter", "backend"}),
        ),
        Backend(
            "proxqp", "proxsuite", "solvers", False,
            lambda tol: {"eps_abs": tol, "eps_rel": 0.0, "max_iter": ITERATION_LIMIT},
            frozenset({"eps_abs", "eps_rel", "max_iter", "rho", "mu_eq", "mu_in",
                       "check_duality_gap", "eps_duality_gap_abs", "eps_duality_gap_rel",
                       "backend"}),
        ),
        Backend(
            "highs", "highspy", "solvers", True,
            # HiGHS adds qp_regularization_value (1e-7 by default) to the Hessian, which moves the
            # SVR duals' zero blocks by ~1e-5 relative: tie it to the requested accuracy.
            lambda tol: {"primal_feasibility_tolerance": tol, "dual_feasibility_tolerance": tol,
                         "qp_regularization_value": 1e-2 * tol, "time_limit": TIME_LIMIT_S,
                         "qp_iteration_limit": ITERATION_LIMIT},
            frozenset({"primal_feasibility_tolerance", "dual_feasibility_tolerance", "time_limit",
                       "qp_iteration_limit", "qp_regularization_value"}),
        ),
        Backend(
            "daqp", "daqp", "solvers", False,
            # eps_prox > 0 turns on DAQP's proximal-point outer loop, which solves semidefinite
            # QPs exactly (the SVR duals' P is singular by construction).
            lambda tol: {"primal_tol": tol, "dual_tol": tol, "eps_prox": 1e-6,
                         "iter_limit": ITERATION_LIMIT},
            frozenset({"primal_tol", "dual_tol", "zero_tol", "iter_limit", "eps_prox", "eta_prox",
                       "prox_iter_limit", "progress_tol", "cycle_tol", "pivot_tol", "rho_soft"}),
        ),
        Backend(
            "quadprog", "quadprog", "solvers", False,
            lambda tol: {},
            frozenset(),
            needs_positive_definite=True,
        ),
        Backend(
            "scs", "scs", "solvers", True,
            lambda tol: {"eps_abs": tol, "eps_rel": tol, "max_iters": 1_000_000,
                         "time_limit_secs": TIME_LIMIT_S},
            frozenset({"eps_abs", "eps_rel", "eps_infeas", "max_iters", "time_limit_secs",
                       "acceleration_lookback", "normalize", "scale", "adaptive_scale"}),
        ),
        Backend(
            "cvxopt", "cvxopt", "solvers", False,
            lambda tol: {"abstol": tol, "reltol": tol, "feastol": tol, "maxiters": 200},
            frozenset({"abstol", "reltol", "feastol", "maxiters", "refinement"}),
        ),
        Backend(
            "qpalm", "qpalm", "solvers", True,
            lambda tol: {"eps_abs": tol, "eps_rel": tol, "max_iter": ITERATION_LIMIT},
            frozenset({"eps_abs", "eps_rel", "eps_abs_in", "eps_rel_in", "max_iter", "rho",
                       "sigma_max", "scaling", "proximal", "gamma_init", "gamma_max"}),
        ),
        Backend(
            "cvxpy", "cvxpy", None, True,
            lambda tol: {"tol": tol},
            frozenset({"solver"}),
        ),
    )
}

#: Solvers cvxpy may hand the QP to, with how ``tol`` maps onto each.
CVXPY_SOLVERS: dict[str, Callable[[float], dict[str, Any]]] = {
    "CLARABEL": BACKENDS["clarabel"].tolerances,
    "OSQP": lambda tol: {"eps_abs": tol, "eps_rel": tol, "polish": True, "max_iter": 100_000},
}


def _backend(name: str) -> Backend:
    if name not in BACKENDS:
        raise ProblemError(f"unknown backend {name!r}; known backends: {sorted(BACKENDS)}")
    return BACKENDS[name]


def _installed(backend: Backend) -> bool:
    try:
        importlib.import_module(backend.package)
    except ImportError:
        return False
    return True


def available_backends() -> list[str]:
    """Names of the QP backends installed here (the others need their extra)."""
    return [name for name, backend in BACKENDS.items() if _installed(backend)]


def require_backend(name: str) -> Backend:
    """The :class:`Backend` ``name``, or :class:`BackendNotAvailableError` naming the extra."""
    backend = _backend(name)
    if not _installed(backend):
        raise BackendNotAvailableError(
            f"backend {name!r} is not installed; install it with: {backend.install_hint}"
        )
    return backend


def backend_version(name: str) -> str:
    """Installed version of a backend's package (``"unknown"`` when it has no metadata)."""
    try:
        return version(BACKENDS[name].package)
    except PackageNotFoundError:
        return "unknown"


def _status_from_text(text: str) -> str:
    text = text.lower()
    if "infeas" in text:
        return "infeasible"
    if "iter" in text:
        return "max_iter"
    if "time" in text:
        return "time_limit"
    return "failed"


def _iterations(extras: dict[str, Any]) -> int | None:
    for key in ("iterations", "iter"):
        if key in extras:
            return int(np.ravel(extras[key])[0])  # quadprog reports [iterations, inactive]
    info = extras.get("info")
    for key in ("iter", "iterations"):
        if info is not None and hasattr(info, key):
            return int(getattr(info, key))
    return None


def _validated_settings(backend: Backend, tol: float, options: dict[str, Any]) -> dict[str, Any]:
    unknown = sorted(set(options) - backend.options)
    if unknown:
        raise ProblemError(
            f"unknown option(s) {unknown} for backend {backend.name!r}; "
            f"valid options: {sorted(backend.options) or 'none'}"
        )
    return {**backend.tolerances(tol), **options}


def _convert(M: Any, sparse: bool) -> Any:
    if M is None:
        return None
    if sparse:
        return M if sp.issparse(M) else sp.csc_matrix(M)
    return M.toarray() if sp.issparse(M) else M


@functools.cache
def _swallow_highs_banner() -> None:
    """HiGHS prints its banner once per process, from its first solver object, before any option
    can turn logging off: build that object with the stdout file descriptor sent to /dev/null."""
    import highspy

    try:
        saved = os.dup(1)
    except OSError:  # no stdout descriptor: nothing to keep clean
        return
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            highspy.Highs()
    finally:
        os.dup2(saved, 1)
        os.close(saved)


#: What a backend adapter returns: the point ``(x, y, z, z_box)``, the status and the solver record.
Outcome = tuple[Point, str, SolverRecord]


def _solve_qpsolvers(problem: QuadraticProgram, backend: Backend, settings: dict[str, Any],
                     initvals) -> Outcome:
    import qpsolvers

    if backend.name == "highs":
        _swallow_highs_banner()
    start = time.perf_counter()
    P = _convert(problem.P, backend.sparse)
    if backend.needs_positive_definite:
        delta = PD_REGULARISATION * max(1.0, float(np.max(np.abs(problem.P.diagonal()))))
        P = P + delta * (sp.eye(problem.n, format="csc") if sp.issparse(P) else np.eye(problem.n))
        settings = {**settings, "_pd_regularisation": delta}
    qp = qpsolvers.Problem(
        P, problem.q, _convert(problem.G, backend.sparse), problem.h,
        _convert(problem.A, backend.sparse), problem.b, problem.lb, problem.ub,
    )
    build_time = time.perf_counter() - start
    solver_settings = {k: v for k, v in settings.items() if not k.startswith("_")}
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # backends warn on failure; the status below says it
        try:
            result = qpsolvers.solve_problem(qp, solver=backend.name, initvals=initvals,
                                             **solver_settings)
        except Exception as err:  # a backend crash becomes a SolverError naming it
            raise SolverError(f"backend {backend.name!r} raised {type(err).__name__}: {err}",
                              backend.name, "failed") from err
    solve_time = time.perf_counter() - start
    extras = result.extras or {}
    status = "optimal" if result.found else _status_from_text(str(extras.get("status", "")))
    record = SolverRecord(backend.name, backend_version(backend.name), settings, build_time,
                          solve_time, _iterations(extras))
    return (result.x, result.y, result.z, result.z_box), status, record


def _solve_cvxpy(problem: QuadraticProgram, settings: dict[str, Any], initvals) -> Outcome:
    import cvxpy as cp

    solver = str(settings.get("solver", "CLARABEL")).upper()
    if solver not in CVXPY_SOLVERS:
        raise ProblemError(f"cvxpy solver must be one of {sorted(CVXPY_SOLVERS)}, got {solver!r}")
    tol = settings["tol"]
    start = time.perf_counter()
    x = cp.Variable(problem.n)
    cost = 0.5 * cp.quad_form(x, cp.psd_wrap(problem.P)) + problem.q @ x
    constraints, names = [], []
    if problem.A is not None:
        constraints.append(problem.A @ x == problem.b)
        names.append("y")
    if problem.G is not None:
        constraints.append(problem.G @ x <= problem.h)
        names.append("z")
    finite_lb = None if problem.lb is None else np.isfinite(problem.lb)
    finite_ub = None if problem.ub is None else np.isfinite(problem.ub)
    if finite_lb is not None and finite_lb.any():
        constraints.append(x[finite_lb] >= problem.lb[finite_lb])
        names.append("lb")
    if finite_ub is not None and finite_ub.any():
        constraints.append(x[finite_ub] <= problem.ub[finite_ub])
        names.append("ub")
    model = cp.Problem(cp.Minimize(cost), constraints)
    build_time = time.perf_counter() - start
    start = time.perf_counter()
    try:
        model.solve(solver=solver, **CVXPY_SOLVERS[solver](tol))
    except cp.error.SolverError as err:
        raise SolverError(f"backend 'cvxpy' ({solver}) failed: {err}", "cvxpy", "failed") from err
    solve_time = time.perf_counter() - start
    if model.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or x.value is None:
        record = SolverRecord("cvxpy", backend_version("cvxpy"), settings, build_time, solve_time)
        return (None, None, None, None), _status_from_text(model.status), record
    duals = {name: np.atleast_1d(np.asarray(c.dual_value, dtype=float))
             for name, c in zip(names, constraints, strict=False)}
    z_box = None
    if "lb" in duals or "ub" in duals:
        z_box = np.zeros(problem.n)
        if "lb" in duals:
            z_box[finite_lb] -= duals["lb"]
        if "ub" in duals:
            z_box[finite_ub] += duals["ub"]
    iterations = model.solver_stats.num_iters if model.solver_stats else None
    record = SolverRecord("cvxpy", backend_version("cvxpy"), {**settings, "solver": solver},
                          build_time, solve_time, iterations)
    return (np.asarray(x.value, dtype=float), duals.get("y"), duals.get("z"),
            z_box), "optimal", record


def solve_qp(
    problem: QuadraticProgram,
    backend: str = "clarabel",
    *,
    tol: float = 1e-8,
    check_tol: float | None = None,
    initvals: NDArray[np.float64] | None = None,
    options: Mapping[str, Any] | None = None,
    **settings: Any,
) -> Solution:
    """Solve a :class:`QuadraticProgram` with one backend and check its certificates.

    Parameters
    ----------
    problem
        The QP.
    backend
        A name from :data:`BACKENDS` (see :func:`available_backends`).
    tol
        Requested accuracy, mapped onto the backend's own tolerances.
    check_tol
        Largest relative primal residual, dual residual and duality gap accepted; defaults to
        :data:`~svrqp.solution.DEFAULT_CHECK_FACTOR`
        ``* tol`` (:func:`~svrqp.solution.check_limit`).
    initvals
        Warm start for backends that accept one.
    options
        Backend settings as a mapping: the way to pass a setting whose name is also a
        parameter of this function (PIQP's and ProxQP's
        ``backend``: ``options={"backend": "sparse"}``).
    **settings
        Backend settings as keywords (merged with ``options``; a name given both ways is an
        error). Unknown names are rejected with the list of valid ones.

    Raises
    ------
    SolverError
        The backend failed or its solution misses ``check_tol``.
    """
    if not np.isfinite(tol) or tol <= 0:
        raise ProblemError(f"tol must be a positive number, got {tol!r}")
    check_tol = check_limit(tol, check_tol)
    spec = require_backend(backend)
    twice = sorted(set(options or {}) & set(settings))
    if twice:
        raise ProblemError(f"option(s) {twice} given both in options= and as keywords; give each "
                           f"once")
    settings = _validated_settings(spec, tol, {**(options or {}), **settings})
    if spec.name == "cvxpy":
        outcome = _solve_cvxpy(problem, settings, initvals)
    else:
        outcome = _solve_qpsolvers(problem, spec, settings, initvals)
    point, status, record = outcome
    x = point[0]
    if x is None or status != "optimal" or not np.all(np.isfinite(x)):
        raise SolverError(f"backend {backend!r} did not solve {problem.name!r} (status: {status})",
                          backend, status)
    settings = {**record.settings, "tol": tol, "check_tol": check_tol}
    if "_pd_regularisation" in settings:  # what the added diagonal changed in the objective
        settings["_pd_objective_shift"] = 0.5 * settings["_pd_regularisation"] * float(x @ x)
    solution = Solution.of_qp(problem, point, dataclasses.replace(record, settings=settings))
    require_certificates(solution, problem, check_tol)
    return solution
