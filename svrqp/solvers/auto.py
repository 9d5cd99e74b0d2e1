r"""``EpsilonSVR(solver="auto")``: the fastest exact
path for the problem, certified on the stated QP.

**The rule** (measured; see ``docs/solvers.md`` and ``benchmarks/results/epsilon_svr_vs_libsvm*``):

1. ``"smo_crossover"`` (:mod:`svrqp.solvers.warm_start`): libsvm's SMO at a loose tolerance, then
   the exact active-set crossover. First for every kernel and size: a loose SMO run costs a fraction
   of a tight one, and the crossover needs only the kernel columns of the support vectors.
2. ``"dual_ipm"`` (:func:`svrqp.solvers.dual_ipm.exact.solve_exact_from_data`, or
   :func:`~svrqp.solvers.dual_ipm.exact.solve_exact` on a precomputed kernel): the interior point on
   the reduced n×n system (or a low-rank factor) and the same crossover, when the first path does
   not reach the exact optimum (the crossover did not
   settle, or its certificate misses ``check_tol``).

Each answer is certified on the QP of ``formulation``
(:mod:`svrqp.formulations.epsilon_svr_residuals`): the relative primal residual, dual residual and
duality gap must be at most ``check_tol``. When no path certifies, :class:`SolverError` names every
path tried and why it was rejected — never an uncertified answer.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp._version import __version__
from svrqp.exceptions import SolverError, SvrqpError
from svrqp.formulations.epsilon_svr import DualScaling
from svrqp.formulations.epsilon_svr_certificate import require_model_certificate
from svrqp.formulations.epsilon_svr_residuals import kernel_scale, stated_dual
from svrqp.kernels import gram
from svrqp.solution import (
    Solution,
    SolverRecord,
    check_limit,
    rejected_coefficients,
    require_certificates,
)
from svrqp.solvers import dual_ipm
from svrqp.solvers.dual_ipm.exact import ExactSettings
from svrqp.solvers.dual_qp import DualFit, DualSettings
from svrqp.solvers.warm_start import solve_warm_started

#: ``EpsilonSVR(solver=AUTO)``: choose the path (module docstring).
AUTO = "auto"
#: ``EpsilonSVR(solver=SMO_CROSSOVER)``: the loose-SMO warm start and exact crossover alone.
SMO_CROSSOVER = "smo_crossover"
#: The paths ``auto`` tries, in order.
AUTO_ORDER: tuple[str, ...] = (SMO_CROSSOVER, "dual_ipm")


def _smo_crossover(X, y, C, epsilon, kernel_parameters, tol):
    fit = solve_warm_started(X, y, C, epsilon, kernel_parameters)
    settings = {"smo_iterations": fit.smo_iterations, "screened_points": fit.screened,
                "crossover_steps": fit.crossover_steps, "crossover_exact": fit.exact}
    return fit.beta, fit.intercept, fit.Kbeta, settings, fit.times_s


def _dual_ipm(X, y, C, epsilon, kernel_parameters, tol):
    if kernel_parameters["kernel"] == "precomputed":
        fit = dual_ipm.solve_exact(X, y, C, epsilon, tol=tol)
    else:
        fit = dual_ipm.solve_exact_from_data(X, y, C, epsilon, kernel_parameters,
                                             settings=ExactSettings(tol=tol))
    support = np.flatnonzero(fit.beta)
    Kbeta = _kernel_times(X, kernel_parameters, support, fit.beta[support])
    settings = {"ipm_iterations": fit.ipm.iterations, "ipm_converged": fit.ipm.converged,
                "crossover_steps": fit.crossover.steps, "crossover_exact": fit.crossover.exact,
                "low_rank_path": fit.low_rank}
    return fit.beta, fit.intercept, Kbeta, settings, fit.times_s


PATHS: dict[str, Callable[..., tuple]] = {SMO_CROSSOVER: _smo_crossover, "dual_ipm": _dual_ipm}


def _kernel_times(X: NDArray[np.float64], kernel_parameters: dict[str, Any], idx: NDArray[np.intp],
                  coefficients: NDArray[np.float64]) -> NDArray[np.float64]:
    """:math:`K_{:, idx}` ``coefficients`` (a precomputed ``X`` is the Gram matrix itself)."""
    if kernel_parameters["kernel"] == "precomputed":
        return X[:, idx] @ coefficients
    return gram(X, X[idx], **kernel_parameters) @ coefficients


def solve_path(path: str, X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
               *, kernel_parameters: dict[str, Any],
               settings: DualSettings | None = None) -> DualFit:
    """Run one exact path and certify its answer.

    Returns the :class:`~svrqp.solvers.dual_qp.DualFit` of every dual fit, without the
    QP (``problem`` is ``None``: it is never formed); ``polished`` says whether the crossover
    reached the exact optimum.

    Parameters
    ----------
    path
        A key of :data:`PATHS`.
    X
        Training inputs (the training Gram matrix when ``kernel_parameters["kernel"]`` is
        ``"precomputed"``).
    kernel_parameters
        ``kernel``, ``gamma``, ``degree``, ``coef0`` as in :func:`svrqp.kernels.gram`.
    settings
        The dual QP the answer is certified on (``"split"`` or ``"stacked"``), the requested
        accuracy and the largest relative certificate accepted (``None``: ``DualSettings()``,
        the split form, 1e-8 and ``100·tol``).

    Raises
    ------
    SolverError
        When a certificate of the stated QP or of the returned model exceeds ``check_tol``
        (an answer whose crossover did not settle is judged by its certificates like any other).
    """
    settings = DualSettings() if settings is None else settings
    tol = settings.tol
    check_tol = check_limit(tol, settings.check_tol)
    C, epsilon = float(C), float(epsilon)  # an int C would overflow the crossover's int8 states
    start = time.perf_counter()
    scaling = DualScaling.of_targets(y)  # the paths' tolerances are absolute in units of y
    scaled_beta, scaled_b, scaled_Kbeta, path_settings, times_s = PATHS[path](
        X, *scaling.scaled(y, C, epsilon), kernel_parameters, tol)
    beta, b = scaling.unscaled(scaled_beta, scaled_b, C)
    Kbeta = scaling.beta_scale * scaled_Kbeta
    solve_time = time.perf_counter() - start
    stated = stated_dual(settings.formulation, y, C, epsilon, beta, b, Kbeta,
                         kernel_scale(X, kernel_parameters))
    record = SolverRecord(path, f"svrqp {__version__}",
                          {"tol": tol, "check_tol": check_tol, **path_settings, "times_s": times_s,
                           "scaling": scaling._asdict()},
                          build_time=time.perf_counter() - start - solve_time,
                          solve_time=solve_time)
    solution = Solution.of_stated(stated, record)
    with rejected_coefficients(beta):
        require_certificates(solution, stated.name, check_tol)
        require_model_certificate(solution.residuals, check_tol, path)
    return DualFit(beta, b, None, solution, bool(path_settings["crossover_exact"]))


def solve_auto(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float, *,
               kernel_parameters: dict[str, Any],
               settings: DualSettings | None = None) -> DualFit:
    """Try the paths of :data:`AUTO_ORDER` until one certifies (arguments as :func:`solve_path`).

    ``fit.solution.backend`` names the path that certified; ``fit.solution.settings["rejected"]``
    lists the paths tried before it and why they were rejected.

    Raises
    ------
    SolverError
        When no path certifies; the message names each path tried and why it failed.
    """
    rejected: list[str] = []
    sizes: list[float] = []  # sum |beta| of the answers rejected
    for path in AUTO_ORDER:
        try:
            fit = solve_path(path, X, y, C, epsilon, kernel_parameters=kernel_parameters,
                             settings=settings)
        except (SvrqpError, np.linalg.LinAlgError) as error:
            rejected.append(f"{path}: {error}")
            size = getattr(error, "coefficient_l1", None)
            sizes += [size] if size else []  # a rejected all-zero answer says nothing of the size
            continue
        fit.solution.settings["rejected"] = rejected
        return fit
    error = SolverError("solver='auto' found no path that certifies the epsilon-SVR dual; tried "
                        + "; ".join(rejected), AUTO, "failed")
    error.coefficient_l1 = max(sizes, default=None)
    raise error
