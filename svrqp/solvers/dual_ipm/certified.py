"""The exact dual of :mod:`svrqp.solvers.dual_ipm` certified on a stated QP, as every dual fit is.

:func:`solve_dual_ipm` is what ``EpsilonSVR(solver="dual_ipm")`` runs: the interior point and
the crossover find :math:`(\\beta, b)`, and the same rounding and certificate as a QP backend's
answer (:func:`svrqp.solvers.dual_qp.certified_dual_fit`) turn it into a
:class:`~svrqp.solvers.dual_qp.DualFit` on the split or stacked QP.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp._version import __version__
from svrqp.exceptions import ProblemError, SingularSystemError, SolverError
from svrqp.formulations.epsilon_svr import DualScaling
from svrqp.solution import SolverRecord, check_limit
from svrqp.solvers.dual_ipm.exact import (
    ExactSettings,
    solve_exact,
    solve_exact_from_data,
)
from svrqp.solvers.dual_qp import DualFit, DualProblem, DualSettings, certified_dual_fit

#: The backend name of a ``dual_ipm`` solution (``EpsilonSVR(solver=DUAL_IPM)``).
DUAL_IPM = "dual_ipm"
#: The QP statements a ``dual_ipm`` solution is certified on (the primal has no kernel matrix).
DUAL_FORMULATIONS: tuple[str, ...] = ("split", "stacked")


def solve_dual_ipm(K: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
                   settings: DualSettings | None = None, *, X: NDArray[np.float64] | None = None,
                   kernel_parameters: dict[str, Any] | None = None) -> DualFit:
    """Solve the ε-SVR dual with :mod:`svrqp.solvers.dual_ipm`
    and certify it on the QP ``settings.formulation``.

    With the inputs ``X`` and the ``kernel_parameters`` of K (an RBF or polynomial kernel),
    :func:`~svrqp.solvers.dual_ipm.exact.solve_exact_from_data` runs: a low-rank interior point
    guides the exact crossover when the kernel's numerical rank is low (smooth data such as
    temperatures), and ``K`` is used on its dense fallback. Otherwise
    :func:`~svrqp.solvers.dual_ipm.exact.solve_exact` runs on ``K``.

    Returns the same :class:`~svrqp.solvers.dual_qp.DualFit` as
    :func:`~svrqp.solvers.dual_qp.solve_dual` (``polished`` says whether the crossover
    reached the exact optimum), certified the same way on the returned coefficients. Raises
    :class:`~svrqp.exceptions.SolverError` when a relative certificate exceeds
    ``settings.check_tol`` (default ``100·tol``).
    """
    settings = DualSettings() if settings is None else settings
    if settings.formulation not in DUAL_FORMULATIONS:
        raise ProblemError(f"solver={DUAL_IPM!r} solves a kernel dual: formulation must be one of "
                           f"{DUAL_FORMULATIONS}, got {settings.formulation!r}")
    tol = settings.tol
    check_tol = check_limit(tol, settings.check_tol)
    start = time.perf_counter()
    # a float C: an int would overflow int8 states
    dual = DualProblem.of(settings.formulation, K, y, C, epsilon)
    build_time = time.perf_counter() - start
    scaling = DualScaling.of_targets(y)  # its tolerances are absolute in the units of y
    scaled = scaling.scaled(y, dual.C, dual.epsilon)
    try:
        if X is None:
            fit = solve_exact(K, *scaled, tol=tol)
        else:
            fit = solve_exact_from_data(X, *scaled, kernel_parameters,
                                        settings=ExactSettings(tol=tol), K=K)
    except SingularSystemError as err:  # a solver failure: the fallback may still answer
        raise SolverError(f"{DUAL_IPM!r} failed: {err} (or K's rounding exceeds the interior "
                          f"point's diagonal)", DUAL_IPM, "failed") from err
    record = SolverRecord(
        DUAL_IPM, f"svrqp {__version__}",
        {"tol": tol, "check_tol": check_tol, "ipm_iterations": fit.ipm.iterations,
         "ipm_converged": fit.ipm.converged,
         "crossover_steps": fit.crossover.steps, "crossover_exact": fit.crossover.exact,
         "low_rank_path": fit.low_rank, "scaling": scaling._asdict()},
        build_time=build_time, solve_time=sum(fit.times_s.values()), iterations=fit.ipm.iterations)
    beta, _ = scaling.unscaled(fit.beta, fit.intercept, dual.C)
    return certified_dual_fit(dual, beta, record, check_tol, fit.crossover.exact)
