r"""The ε-SVR solved: the one place that picks a solver, falls back, and certifies the answer.

Everything above the solvers that needs an ε-SVR fit asks this module, and only this module:

* :func:`solve_epsilon_svr` is what :meth:`svrqp.estimators.kernel.EpsilonSVR.fit` runs. It
  dispatches ``solver`` to one exact path — :mod:`svrqp.solvers.auto` (``"auto"``,
  ``"smo_crossover"``), :func:`svrqp.solvers.dual_ipm.certified.solve_dual_ipm`
  (``"dual_ipm"``), :func:`svrqp.solvers.dual_qp.solve_dual` (a stock QP backend on a dual) or
  :func:`svrqp.solvers.qp_backends.solve_qp` on the linear primal (:func:`_solve_primal`) —
  and, when that path raises :class:`~svrqp.exceptions.SolverError`, solves once more with the
  other exact path (:data:`FALLBACK_SOLVER` for ``dual_ipm`` and ``auto``, ``dual_ipm`` for a
  backend), saying so in :attr:`SVRFit.solver` and :attr:`SVRFit.fallback_reason`.
* :func:`require_representable` refuses, with a :class:`~svrqp.exceptions.ProblemError` naming
  the scale, a model whose own predictions round by more than :data:`REPRESENTATION_LIMIT`·std(y)
  (coefficients up to C times kernel values beyond double precision: a linear kernel on large
  inputs), whether a solver returned it or every solver failed on it.
* :func:`fit_on_gram` is what the tuning loops run on a fold's shared Gram matrix, warm-started
  along an ascending C grid (:data:`WARM_START_BACKENDS`, :func:`warm_start_applies`).

**One certificate.** Every answer is judged by the returned model's own certificate
(:func:`svrqp.formulations.epsilon_svr_certificate.model_certificate`: the ε-SVR optimality
conditions at :math:`(\beta, b)`, in the units of the data); the estimator's answers are, in
addition, written on the stated QP and its relative residuals checked
(:func:`svrqp.solution.require_certificates`), so a solution's record says how far it is from
the QP the user asked for.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError, SolverError
from svrqp.formulations import epsilon_svr, epsilon_svr_certificate
from svrqp.formulations.epsilon_svr_residuals import kernel_scale
from svrqp.kernels import training_gram
from svrqp.problems import QuadraticProgram
from svrqp.solution import Solution, check_limit, rejected_coefficients, require_certificates
from svrqp.solvers import dual_ipm, dual_qp
from svrqp.solvers.auto import AUTO, SMO_CROSSOVER, solve_auto, solve_path
from svrqp.solvers.dual_ipm.certified import DUAL_FORMULATIONS, DUAL_IPM, solve_dual_ipm
from svrqp.solvers.dual_qp import DualSettings
from svrqp.solvers.qp_backends import BACKENDS, require_backend, solve_qp

__all__ = ["AUTO", "DUAL_FORMULATIONS", "DUAL_IPM", "FALLBACK_SOLVER", "PRIMAL_AUTO_BACKEND",
           "SMO_CROSSOVER", "SOLVERS", "SVRFit", "SVRTask", "SolveOptions", "WARM_CROSSOVER_STEPS",
           "REPRESENTATION_LIMIT", "WARM_START_BACKENDS", "fit_on_gram", "gram_solver",
           "prediction_rounding", "require_representable", "solve_epsilon_svr",
           "warm_start_applies"]

#: Every value ``EpsilonSVR.solver`` accepts: the automatic choice, svrqp's exact paths and the QP
#: backends.
SOLVERS: tuple[str, ...] = (AUTO, SMO_CROSSOVER, DUAL_IPM, *BACKENDS)
#: ``solver="auto"`` on the linear primal QP (a sparse QP with no kernel matrix: a stock backend).
PRIMAL_AUTO_BACKEND = "clarabel"
#: Where a failed ``dual_ipm`` fit falls back to (a failed QP backend falls back to ``dual_ipm``).
FALLBACK_SOLVER = "clarabel"


@dataclass(frozen=True)
class SVRTask:
    """What is solved: the ε-SVR of ``C`` and ``epsilon`` with a kernel.

    ``kernel_parameters`` are ``kernel``, ``gamma`` (resolved to a number), ``degree`` and
    ``coef0`` as in :func:`svrqp.kernels.gram`; with ``kernel="precomputed"`` the inputs handed
    to :func:`solve_epsilon_svr` are the training Gram matrix itself.
    """

    C: float
    epsilon: float
    kernel_parameters: dict[str, Any]


@dataclass(frozen=True)
class SolveOptions:
    """How it is solved: ``EpsilonSVR``'s ``solver``, ``formulation``, ``tol``, ``check_tol`` and
    ``fallback``."""

    solver: str = AUTO  #: a value of :data:`SOLVERS`
    formulation: str = "split"  #: the QP certified on: "split", "stacked" or "primal" (linear)
    tol: float = 1e-8  #: requested accuracy
    check_tol: float | None = None  #: largest relative certificate accepted (None: 100·tol)
    fallback: bool = True  #: solve again with the other exact path when the first fails


@dataclass(frozen=True)
class SVRFit:
    """A certified ε-SVR answer (:func:`solve_epsilon_svr`)."""

    beta: NDArray[np.float64]  #: all n coefficients :math:`\alpha^* - \alpha`, 0 off the support
    intercept: float  #: the bias b
    problem: QuadraticProgram | None  #: the QP solved, in the data's units (None: never formed)
    solution: Solution  #: its certificate-checked solution, at the returned (β, b)
    polished: bool  #: whether an active-set polish or crossover replaced the solver's coefficients
    solver: str  #: the solver whose answer this is (for "auto": the path it chose)
    fallback_reason: str | None = None  #: why the solver asked for was not used (its error)
    coef: NDArray[np.float64] | None = None  #: the primal weights w (``formulation="primal"`` only)


def solve_epsilon_svr(X: NDArray[np.float64], y: NDArray[np.float64], task: SVRTask,
                      options: SolveOptions = SolveOptions()) -> SVRFit:
    """Solve the ε-SVR of ``task`` on (X, y) as ``options`` say, falling back once (module
    docstring).

    Raises
    ------
    ProblemError
        A solver that cannot solve ``options.formulation`` (``dual_ipm`` or ``smo_crossover``
        on the primal).
        A model that double precision cannot represent (:func:`require_representable`): the
        answer, or the largest of the answers the solvers rejected.
    SolverError
        When the solver fails and ``options.fallback`` is false, or when the fallback fails too
        (the message gives both reasons).
    """
    scale = kernel_scale(X, task.kernel_parameters)
    try:
        fit = _solve_with_fallback(X, y, task, options)
    except SolverError as err:
        if err.coefficient_l1 is not None:  # judged by the answers the solvers rejected
            require_representable(y, err.coefficient_l1, scale, task.C, str(err))
        worst = prediction_rounding(y, task.C * y.size, scale)  # every coefficient at ±C
        if worst <= REPRESENTATION_LIMIT:
            raise
        error = SolverError(f"{err}; {_scale_advice(task.C, scale, worst, 'could round')}",
                            err.backend, err.status)
        error.coefficient_l1 = err.coefficient_l1
        raise error from err
    require_representable(y, float(np.abs(fit.beta).sum()), scale, task.C, None)
    return fit


#: The largest rounding of a model's own predictions accepted, relative to std(y): the accuracy
#: an answer is held to (DESIGN §3, predictions within 1e-5·std(y) of a reference).
REPRESENTATION_LIMIT = 1e-5


def prediction_rounding(y: NDArray[np.float64], l1: float, scale: float) -> float:
    r"""How much predictions :math:`\sum_i \beta_i k(x_i, x) + b` with
    :math:`\sum_i|\beta_i| =` ``l1`` and kernel values up to ``scale`` (:math:`\max_i K_{ii}`)
    round, relative to std(y): :math:`u\,k\,\lVert\beta\rVert_1 / s_y` (u the unit roundoff;
    Higham 2002, §3.1; :math:`s_y` as in the model certificate)."""
    s_y = epsilon_svr_certificate.target_scale(y)
    return float(np.finfo(float).eps) * scale * l1 / s_y


def require_representable(y: NDArray[np.float64], l1: float, scale: float, C: float,
                          failure: str | None) -> None:
    r"""Raise :class:`ProblemError` when a model with :math:`\sum_i|\beta_i| =` ``l1`` predicts
    with a rounding (:func:`prediction_rounding`) above :data:`REPRESENTATION_LIMIT`·std(y).

    Such a model's coefficients cancel beyond double precision: a linear kernel on inputs of 1e5
    (:math:`k \approx 10^{11}`) with C = 10 and 22 coefficients at the bound rounds by
    2e-3·std(y). A certificate cannot tell it from a wrong one, and on inputs of 6e7 no solver
    returns it (issue #39, finding 15). ``failure`` is the solvers' error when none answered
    (``l1`` is then that of the largest answer they rejected: an estimate, as those answers are
    not optimal).
    """
    rounding = prediction_rounding(y, l1, scale)
    if rounding > REPRESENTATION_LIMIT:
        raise ProblemError(
            f"the epsilon-SVR model cannot be represented in double precision at this input "
            f"scale: {_scale_advice(C, scale, rounding, 'round')}"
            + ("" if failure is None else f" (no solver answered: {failure})"))


def _scale_advice(C: float, scale: float, rounding: float, verb: str) -> str:
    """What the model's predictions add up and how much they ``verb`` by; what to do."""
    return (f"its predictions add coefficients up to C = {C:g} times kernel values up to "
            f"max K(x, x) = {scale:.3g} (inputs of size {np.sqrt(scale):.3g}), which {verb} by "
            f"{rounding:.1e}·std(y) > {REPRESENTATION_LIMIT:g}·std(y) in double precision; "
            f"standardise X and y (e.g. sklearn.preprocessing.StandardScaler), or lower C "
            f"or gamma")


def _solve_with_fallback(X: NDArray[np.float64], y: NDArray[np.float64], task: SVRTask,
                         options: SolveOptions) -> SVRFit:
    """The solver of ``options``, then its fallback (:func:`solve_epsilon_svr`)."""
    errors: list[SolverError] = []
    for solver, settings in _attempts(options):
        try:
            fit = _solve_once(X, y, task, solver, settings)
        except SolverError as err:
            errors.append(err)
            continue
        if not errors:
            return fit
        coef = fit.beta @ X if options.formulation == "primal" else None
        return dataclasses.replace(fit, fallback_reason=str(errors[0]), coef=coef)
    first, *second = errors
    if not second:
        raise first
    error = SolverError(f"{first}; the fallback {solver!r} failed too: {second[0]}",
                        options.solver, first.status)
    sizes = [err.coefficient_l1 for err in errors if err.coefficient_l1 is not None]
    error.coefficient_l1 = max(sizes, default=None)
    raise error from second[0]


def _attempts(options: SolveOptions) -> list[tuple[str, DualSettings]]:
    """The requested solver, then, with ``options.fallback``, the other exact path: a fit asked for
    with sound parameters must not fail because one solver did ("auto" on a dual has tried
    ``dual_ipm`` already: its fallback is the rescaled QP backend)."""
    first = (options.solver, DualSettings(options.formulation, options.tol, options.check_tol))
    if not options.fallback:
        return [first]
    dual_auto = options.solver == AUTO and options.formulation != "primal"
    other = FALLBACK_SOLVER if options.solver == DUAL_IPM or dual_auto else DUAL_IPM
    formulation = options.formulation if options.formulation in DUAL_FORMULATIONS else "split"
    return [first, (other, DualSettings(formulation, options.tol, options.check_tol))]


def _solve_once(X: NDArray[np.float64], y: NDArray[np.float64], task: SVRTask, solver: str,
                settings: DualSettings) -> SVRFit:
    """Certified (β, b) from one solver, with no fallback; the training Gram matrix is formed only
    for the paths that take one (``auto`` and ``smo_crossover`` form kernel columns themselves).
    ``SVRFit.solver`` names ``solver``, or for ``"auto"`` the path it chose."""
    if settings.formulation == "primal":
        if solver in (SMO_CROSSOVER, DUAL_IPM):
            raise ProblemError(f"solver={solver!r} solves a kernel dual: formulation must be one "
                               f"of {DUAL_FORMULATIONS}, got 'primal'")
        backend = PRIMAL_AUTO_BACKEND if solver == AUTO else solver
        return _solve_primal(X, y, task, backend, settings)
    kernel_parameters = task.kernel_parameters
    precomputed = kernel_parameters["kernel"] == "precomputed"
    needs_gram = precomputed or solver not in (AUTO, SMO_CROSSOVER)
    K = training_gram(X, kernel_parameters) if needs_gram else None
    if solver in (AUTO, SMO_CROSSOVER):
        run = solve_auto if solver == AUTO else partial(solve_path, SMO_CROSSOVER)
        # the QP is never formed: problem_ is rebuilt on demand (svrqp.estimators.fitted_state)
        fit = run(K if precomputed else X, y, task.C, task.epsilon,
                  kernel_parameters=kernel_parameters, settings=settings)
    elif solver == DUAL_IPM:
        low_rank_possible = kernel_parameters["kernel"] in ("rbf", "poly")  # a linear K: degenerate
        fit = solve_dual_ipm(K, y, task.C, task.epsilon, settings,
                             X=X if low_rank_possible else None,
                             kernel_parameters=kernel_parameters)
    else:
        fit = dual_qp.solve_dual(K, y, task.C, task.epsilon, solver, settings)
    chosen = fit.solution.backend if solver == AUTO else solver
    return SVRFit(fit.beta, fit.intercept, fit.problem, fit.solution, fit.polished, chosen)


def _solve_primal(X: NDArray[np.float64], y: NDArray[np.float64], task: SVRTask, solver: str,
                  settings: DualSettings) -> SVRFit:
    r"""The linear primal: β from the multipliers, rounded and certified like the duals'.

    The backend solves the primal for the targets of
    :class:`~svrqp.formulations.epsilon_svr.DualScaling` (:math:`\tilde y = (y - m)/a`,
    :math:`\tilde\varepsilon = \varepsilon/a`, :math:`\tilde C = C/a`); the primal variables and
    multipliers scale by a (b is shifted by m) back onto the stated primal, where the
    certificates are checked.
    """
    C, epsilon = float(task.C), task.epsilon
    problem = epsilon_svr.build("primal", y, C, epsilon, X=X)
    m, a, _ = scaling = epsilon_svr.DualScaling.of(y, C)
    record = solve_qp(epsilon_svr.build("primal", (y - m) / a, C / a, epsilon / a, X=X), solver,
                      tol=settings.tol, check_tol=settings.check_tol)
    x, z = a * record.x, a * record.z
    x[X.shape[1]] += m
    z_box = None if record.z_box is None else a * record.z_box
    solution = Solution.of_qp(problem, (x, record.y, z, z_box), dataclasses.replace(
        record.record, settings={**record.settings, "scaling": scaling._asdict()}))
    beta = epsilon_svr.beta_from_solution("primal", X.shape[0], solution.x, solution.z)
    with rejected_coefficients(beta):
        require_certificates(solution, problem, record.settings["check_tol"])
    # Multipliers are as accurate as the backend's tolerance: settle the active sets exactly
    # (K = X Xᵀ column by column), as polish and the crossover do for the duals.
    scale = float(np.max(np.einsum("ij,ij->i", X, X), initial=0.0))
    exact = dual_ipm.crossover(dual_ipm.LinearColumns(X), y, C, float(epsilon), beta,
                               kernel_scale=scale)
    beta = epsilon_svr.returned_coefficients(exact.beta if exact.exact else beta, C,
                                             exact=exact.exact)
    K_beta = X @ (X.T @ beta)
    b = epsilon_svr.intercept_from_residual(y - K_beta, beta, C, epsilon)
    certificate = epsilon_svr_certificate.model_certificate(y, beta, K_beta, b, C, epsilon, scale)
    solution.residuals.update(certificate)
    with rejected_coefficients(beta):
        epsilon_svr_certificate.require_model_certificate(certificate,
                                                          solution.settings["check_tol"], solver)
    return SVRFit(beta, b, problem, solution, exact.exact, solver,
                  coef=solution.x[:X.shape[1]].copy())


# --- the tuning loops: one fit on a fold's shared Gram matrix, warm-started along the C grid ---

#: Backends whose qpsolvers adapter uses ``initvals`` (first-order and augmented-Lagrangian
#: methods); interior-point backends ignore a warm start, so it is not passed to them.
WARM_START_BACKENDS = frozenset({"osqp", "proxqp", "qpalm", "scs"})

#: ``solver="dual_ipm"`` on a Gram matrix: primal–dual active-set steps tried from the previous
#: C's active set before falling back to the interior point (measured on friedman1, n = 1600: a
#: successful warm start takes 1–14 steps; a failed attempt of this length costs about a quarter
#: of a cold fit).
WARM_CROSSOVER_STEPS = 10


def gram_solver(solver: str) -> str:
    """The solver :func:`fit_on_gram` runs for ``solver``: ``"auto"`` is the exact path on a Gram
    matrix, ``dual_ipm``; ``dual_ipm`` and a QP backend (checked installed) are themselves."""
    if solver == AUTO:
        return DUAL_IPM
    if solver != DUAL_IPM:
        require_backend(solver)
    return solver


def warm_start_applies(solver: str) -> bool:
    """Whether :func:`fit_on_gram` with ``solver`` starts from the previous C's solution
    (``dual_ipm``, :data:`WARM_START_BACKENDS`)."""
    return solver == DUAL_IPM or solver in WARM_START_BACKENDS


def fit_on_gram(K: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
                solver: str, tol: float, previous: Any) -> tuple[NDArray[np.float64], float, Any]:
    r"""β (zero off the support), b and what warm-starts the next C, on a Gram matrix ``K``.

    Along an ascending C grid the ε-SVR dual of the previous C is a feasible start of the next
    one (the box :math:`[-C, C]` only grows). ``previous`` is what the previous call returned
    (``None``: a cold start).

    * ``solver="dual_ipm"``: the previous optimum's active set — which coefficients are zero,
      free, or at the bound (moved from :math:`\pm C_{prev}` to :math:`\pm C`) — starts the
      crossover at this C directly; if :data:`WARM_CROSSOVER_STEPS` active-set steps do not reach
      a model that meets the certificate, the interior point and its crossover run
      (:func:`svrqp.solvers.dual_ipm.exact.solve_exact`); an uncertified crossover leaves the
      converged interior-point solution. ``previous`` is ``(β, C)``.
    * a QP backend: :func:`svrqp.solvers.dual_qp.solve_dual`, certified as the estimator's fits,
      with the previous raw QP solution as ``initvals``.

    Raises
    ------
    SolverError
        When no answer can be returned (the caller counts the fit as failed).
    """
    if solver == DUAL_IPM:
        scaling = epsilon_svr.DualScaling.of_targets(y)  # as the estimator's exact paths
        u = scaling.beta_scale
        start = None if previous is None else (previous[0] / u, previous[1] / u)
        beta, b = _exact_dual_along_c(K, *scaling.scaled(y, C, epsilon), tol, start)
        beta, b = scaling.unscaled(beta, b, C)
        return beta, b, (beta, float(C))
    fit = dual_qp.solve_dual(K, y, C, epsilon, solver, DualSettings(tol=tol), initvals=previous)
    return fit.beta, fit.intercept, fit.solution.x


def _exact_dual_along_c(K: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
                        tol: float, previous: tuple[NDArray[np.float64], float] | None
                        ) -> tuple[NDArray[np.float64], float]:
    """The exact dual at C: the crossover from the previous C's active set, else the interior
    point."""
    check_tol = check_limit(tol, None)
    if previous is not None:
        beta_previous, C_previous = previous
        at_bound = np.abs(beta_previous) >= C_previous * (1.0 - epsilon_svr.SV_TOLERANCE)
        guess = np.where(at_bound, np.sign(beta_previous) * C, beta_previous)  # same states, new C
        few_steps = dual_ipm.CrossoverSettings(fast_steps=WARM_CROSSOVER_STEPS, max_steps=0)
        warm = dual_ipm.crossover(dual_ipm.DenseColumns(K), y, C, epsilon, guess,
                                  settings=few_steps,
                                  kernel_scale=float(np.max(np.diagonal(K), initial=0.0)))
        if warm.exact and _certified(K, y, warm.beta, warm.intercept, C, epsilon, check_tol):
            return warm.beta, warm.intercept
    fit = dual_ipm.solve_exact(K, y, C, epsilon, tol=tol)
    settled = fit.crossover
    if settled.exact and _certified(K, y, settled.beta, settled.intercept, C, epsilon, check_tol):
        return settled.beta, settled.intercept
    if fit.ipm.converged:
        return fit.ipm.beta, fit.ipm.intercept
    raise SolverError(f"{DUAL_IPM!r} did not converge at C = {C:g} in {fit.ipm.iterations} "
                      f"iterations and its crossover did not reach the optimum",
                      DUAL_IPM, "max_iter")


def _certified(K: NDArray[np.float64], y: NDArray[np.float64], beta: NDArray[np.float64], b: float,
               C: float, epsilon: float, check_tol: float) -> bool:
    """Whether (β, b) meets the model certificate every ε-SVR answer is held to (module
    docstring)."""
    scale = float(np.max(np.diagonal(K), initial=0.0))
    certificate = epsilon_svr_certificate.model_certificate(y, beta, K @ beta, b, C, epsilon, scale)
    return not epsilon_svr_certificate.failed_model_certificates(certificate, check_tol)
