r"""One fit on a fold's Gram block, and the warm start that carries it along the C grid.

Along the C grid (ascending) the ε-SVR dual of the previous C is a feasible starting point of
the next one (the box :math:`[-C, C]` only grows), so backends that accept a warm start
(:data:`WARM_START_BACKENDS`) get it.

**The fast exact path** (``solver="dual_ipm"``, and the default ``"auto"``): each fit is the exact optimum of
:func:`svrqp.solvers.dual_ipm.exact.solve_exact` (interior point on the reduced system, then an active-set
crossover). Along the C grid the previous optimum's active set — which coefficients are zero,
free, or at the bound (moved from :math:`\pm C_{prev}` to :math:`\pm C`) — starts the crossover at
the next C directly; if :data:`WARM_CROSSOVER_STEPS` primal–dual active-set steps do not reach a
point that satisfies every KKT condition, the fit falls back to the interior point. Either way
the returned coefficients satisfy the KKT conditions to rounding (checked again here, not taken
from the crossover) or are the converged interior-point solution; a fit that is neither counts
as failed.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.estimators.kernel import DUAL_IPM
from svrqp.exceptions import SolverError
from svrqp.formulations import epsilon_svr, epsilon_svr_certificate
from svrqp.solvers import dual_ipm, dual_qp

#: Backends whose qpsolvers adapter uses ``initvals`` (first-order and augmented-Lagrangian
#: methods); interior-point backends ignore a warm start, so it is not passed to them.
WARM_START_BACKENDS = frozenset({"osqp", "proxqp", "qpalm", "scs"})

#: ``solver="dual_ipm"``: primal–dual active-set steps tried from the previous C's active set
#: before falling back to the interior point (measured on friedman1, n = 1600: a successful warm
#: start takes 1–14 steps; a failed attempt of this length costs about a quarter of a cold fit).
WARM_CROSSOVER_STEPS = 10


def warm_start_applies(solver: str) -> bool:
    """Whether a fit with ``solver`` starts from the previous C's solution (``dual_ipm``, :data:`WARM_START_BACKENDS`)."""
    return solver == DUAL_IPM or solver in WARM_START_BACKENDS


def fit_epsilon_svr(
    K: NDArray, y: NDArray, C: float, epsilon: float, solver: str, tol: float, previous: Any
) -> tuple[NDArray, float, Any]:
    """β (zero off the support), b and what warm-starts the next C on a Gram matrix.

    ``previous`` is what the previous fit returned (``None``: a cold start): the raw QP solution
    for the QP backends, ``(β, C)`` for ``dual_ipm``.
    """
    if solver == DUAL_IPM:
        beta, b = _exact_dual_along_c(K, y, float(C), float(epsilon), tol, previous)
        return beta, b, (beta, float(C))
    beta, b, _, solution, _ = dual_qp.solve_dual(K, y, C, epsilon, solver, dual_qp.DualSettings(tol=tol),
                                                 initvals=previous)
    beta = np.where(epsilon_svr.support_mask(beta, C), beta, 0.0)
    return beta, b, solution.x


def _exact_dual_along_c(
    K: NDArray, y: NDArray, C: float, epsilon: float, tol: float, previous: tuple[NDArray, float] | None
) -> tuple[NDArray, float]:
    """The exact dual at C: the crossover from the previous C's active set, else the interior point."""
    if previous is not None:
        beta_previous, C_previous = previous
        at_bound = np.abs(beta_previous) >= C_previous * (1.0 - epsilon_svr.SV_TOLERANCE)
        guess = np.where(at_bound, np.sign(beta_previous) * C, beta_previous)  # same states, new box
        warm = dual_ipm.crossover(lambda idx: K[:, idx], y, C, epsilon, guess,
                                  settings=dual_ipm.CrossoverSettings(fast_steps=WARM_CROSSOVER_STEPS, max_steps=0))
        if warm.exact and _kkt_holds(K, y, warm.beta, warm.intercept, C, epsilon):
            return warm.beta, warm.intercept
    fit = dual_ipm.solve_exact(K, y, C, epsilon, tol=tol)
    if fit.crossover.exact and _kkt_holds(K, y, fit.crossover.beta, fit.crossover.intercept, C, epsilon):
        return fit.crossover.beta, fit.crossover.intercept
    if fit.ipm.converged:
        return fit.ipm.beta, fit.ipm.intercept
    raise SolverError(f"{DUAL_IPM!r} did not converge at C = {C:g} in {fit.ipm.iterations} iterations "
                      f"and its crossover did not reach the optimum", DUAL_IPM, "max_iter")


#: Slack of :func:`_kkt_holds`, relative to C·n (equality) and to 1 + max|y| (tube conditions):
#: ten times the crossover's own, so a different summation order cannot reject its optimum.
KKT_TOL = 1e-8


def _kkt_holds(K: NDArray, y: NDArray, beta: NDArray, b: float, C: float, epsilon: float) -> bool:
    r"""Every ε-SVR optimality condition at (β, b), checked here rather than trusted from the crossover.

    A warm start guessed from another C is far from the states the crossover was designed to
    start from (an interior point's), so its answer is re-checked from first principles: the
    equality :math:`\mathbf 1^\top\beta = 0`, the box, zeros inside the tube, free coefficients
    on it, bounded ones outside.
    """
    slack = KKT_TOL * (1.0 + float(np.max(np.abs(y))))
    if abs(float(beta.sum())) > KKT_TOL * C * beta.size or np.max(np.abs(beta)) > C:
        return False
    residual = epsilon_svr_certificate.multipliers(beta, b, K @ beta, y, epsilon).residual
    state = epsilon_svr_certificate.states(beta, C, 0.0)  # exactly 0 or exactly ±C
    return bool(np.all(epsilon_svr_certificate.kkt_violation(residual, state, epsilon) <= slack))
