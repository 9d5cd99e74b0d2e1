r"""A structure-exploiting interior-point method for the ε-SVR dual, and an exact active-set crossover.

**Problem** (S0 eq. 6 in the stacked variables of :mod:`svrqp.formulations.epsilon_svr`,
:math:`\beta = \alpha^* - \alpha`):

.. math::

    \min_{\alpha, \alpha^*}\ \tfrac12 \beta^\top K \beta + \varepsilon \mathbf 1^\top(\alpha + \alpha^*)
    - y^\top \beta \quad\text{s.t.}\quad \mathbf 1^\top\beta = 0,\quad 0 \le \alpha, \alpha^* \le C .

**Optimality conditions**, with :math:`b` the multiplier of the equality (the bias),
:math:`z, z^* \ge 0` those of :math:`\alpha, \alpha^* \ge 0` and :math:`u, u^* \ge 0` those of
:math:`\alpha, \alpha^* \le C`:

.. math::

    r^* &= K\beta + b\mathbf 1 + \varepsilon - y - z^* + u^* = 0, \\
    r &= -K\beta - b\mathbf 1 + \varepsilon + y - z + u = 0, \\
    r_e &= \mathbf 1^\top \beta = 0, \qquad
    \alpha \circ z = (C - \alpha) \circ u = \alpha^* \circ z^* = (C - \alpha^*) \circ u^* = 0 .

**Reduced Newton system.** Eliminating the multipliers and slacks of one primal–dual Newton step
(with :math:`\Theta = z/\alpha + u/(C - \alpha)` and :math:`\Theta^*` likewise) leaves, with
:math:`d = 1/\Theta + 1/\Theta^*` and :math:`D = \operatorname{diag}(d)`,

.. math::

    (K + D^{-1})\,\Delta\beta + \Delta b\,\mathbf 1 = D^{-1} h, \qquad \mathbf 1^\top \Delta\beta = -r_e,
    \qquad h = g^*/\Theta^* - g/\Theta ,

where :math:`g^*, g` are the right-hand sides of the linearised dual equations (Mehrotra
predictor–corrector terms included). This is an :math:`n \times n` symmetric positive definite
system: solved by a dense LAPACK Cholesky factorisation of :math:`K + D^{-1}` (one per iteration,
used for the predictor, the corrector and the bias), or for a factored kernel
:math:`K = LL^\top` (:mod:`svrqp.formulations.low_rank`) by the Woodbury identity

.. math::

    (D^{-1} + LL^\top)^{-1} = D - DL\,(I_r + L^\top D L)^{-1} L^\top D

in :math:`O(nr^2)`. Generic backends factorise the :math:`(2n+1)`- or :math:`(3n+1)`-dimensional
KKT matrix of the stacked or split QP with a sparse LDLᵀ that cannot see this structure.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError
from svrqp.formulations.epsilon_svr import check_parameters
from svrqp.solvers.dual_ipm.kernel_operators import KernelOperator

#: Fraction of the distance to the boundary that one interior-point step may cover.
STEP_TO_BOUNDARY = 0.995


@dataclass
class IPMResult:
    """Outcome of :func:`interior_point`.

    ``residuals`` holds the relative primal residual :math:`|r_e|`, dual residual
    :math:`\\max(\\lVert r\\rVert_\\infty, \\lVert r^*\\rVert_\\infty)` and complementarity gap at the last iterate.
    """

    beta: NDArray[np.float64]
    intercept: float
    iterations: int
    converged: bool
    residuals: dict[str, float] = field(default_factory=dict)


def _check(y: NDArray[np.float64], C: float, epsilon: float, n: int) -> None:
    check_parameters(y, C, epsilon)
    if y.shape != (n,):
        raise ProblemError(f"y must be a finite vector of length {n}, got shape {y.shape}")


def _max_step(x: NDArray, dx: NDArray) -> float:
    """Largest step in [0, 1] keeping ``x + step * dx >= 0``, for ``x > 0`` (an interior point).

    The step is :math:`1/\\max_i(-dx_i/x_i)` when that maximum exceeds 1: one division and one
    reduction, no boolean masks (this runs eight times per iteration on vectors of length n).
    """
    worst = float(np.max(-dx / x))
    return 1.0 if worst <= 1.0 else 1.0 / worst


def interior_point(kernel: KernelOperator, y: NDArray[np.float64], C: float, epsilon: float, *,
                   tol: float = 1e-8, max_iter: int = 100) -> IPMResult:
    """Mehrotra predictor–corrector on the stacked ε-SVR dual through the reduced system (module docstring).

    Parameters
    ----------
    kernel
        :class:`DenseKernel` or :class:`FactoredKernel`.
    y, C, epsilon
        Targets and SVR parameters.
    tol
        Stop when the relative primal, dual and complementarity residuals are all below ``tol``.
    max_iter
        Iteration limit; ``converged`` is false when it is reached.
    """
    n = kernel.n
    y = np.asarray(y, dtype=float)
    _check(y, C, epsilon, n)
    # Start at the centre of the box with the dual residual split into positive parts.
    a = np.full(n, 0.5 * C)  # alpha
    s = np.full(n, 0.5 * C)  # alpha*
    b = 0.0
    Kbeta = np.zeros(n)
    g_s, g_a = epsilon - y, epsilon + y  # the dual residuals at beta = 0, b = 0
    z_s, u_s = np.maximum(g_s, 0.0) + 1.0, np.maximum(-g_s, 0.0) + 1.0
    z_a, u_a = np.maximum(g_a, 0.0) + 1.0, np.maximum(-g_a, 0.0) + 1.0
    scale = 1.0 + float(np.max(np.abs(y)))
    residuals: dict[str, float] = {}
    for iteration in range(1, max_iter + 1):
        beta = s - a
        r_s = Kbeta + b + epsilon - y - z_s + u_s
        r_a = -Kbeta - b + epsilon + y - z_a + u_a
        r_e = float(beta.sum())
        w_s, w_a = C - s, C - a
        mu = float(s @ z_s + w_s @ u_s + a @ z_a + w_a @ u_a) / (4 * n)
        objective = 0.5 * float(beta @ Kbeta) + epsilon * float(a.sum() + s.sum()) - float(y @ beta)
        residuals = {
            "primal_rel": abs(r_e) / (1.0 + n * C),
            "dual_rel": max(float(np.max(np.abs(r_s))), float(np.max(np.abs(r_a)))) / scale,
            "gap_rel": 4 * n * mu / (1.0 + abs(objective)),
        }
        if max(residuals.values()) <= tol:
            return IPMResult(beta, b, iteration - 1, True, residuals)
        theta_s = z_s / s + u_s / w_s
        theta_a = z_a / a + u_a / w_a
        d = 1.0 / theta_s + 1.0 / theta_a
        solve = kernel.shifted_solver(1.0 / d)
        ones_solution = solve(np.ones(n))

        def newton(rz_s, ru_s, rz_a, ru_a):
            rho_s = -rz_s / s + ru_s / w_s
            rho_a = -rz_a / a + ru_a / w_a
            g_s, g_a = -r_s - rho_s, -r_a - rho_a
            h = g_s / theta_s - g_a / theta_a
            p = solve(h / d)
            db = (p.sum() + r_e) / ones_solution.sum()
            dbeta = p - db * ones_solution
            t = (h - dbeta) / d  # = K dbeta + db, read off the reduced system
            ds, da = (g_s - t) / theta_s, (g_a + t) / theta_a
            return (ds, da, db, (rz_s - z_s * ds) / s, (ru_s + u_s * ds) / w_s,
                    (rz_a - z_a * da) / a, (ru_a + u_a * da) / w_a)

        def step_length(step):
            ds, da, _, dz_s, du_s, dz_a, du_a = step
            return min(_max_step(s, ds), _max_step(w_s, -ds), _max_step(a, da), _max_step(w_a, -da),
                       _max_step(z_s, dz_s), _max_step(u_s, du_s), _max_step(z_a, dz_a), _max_step(u_a, du_a))

        affine = newton(-s * z_s, -w_s * u_s, -a * z_a, -w_a * u_a)
        alpha = step_length(affine)
        ds, da, _, dz_s, du_s, dz_a, du_a = affine
        mu_affine = float((s + alpha * ds) @ (z_s + alpha * dz_s) + (w_s - alpha * ds) @ (u_s + alpha * du_s)
                          + (a + alpha * da) @ (z_a + alpha * dz_a)
                          + (w_a - alpha * da) @ (u_a + alpha * du_a)) / (4 * n)
        sigma_mu = (mu_affine / mu) ** 3 * mu
        step = newton(sigma_mu - s * z_s - ds * dz_s, sigma_mu - w_s * u_s + ds * du_s,
                      sigma_mu - a * z_a - da * dz_a, sigma_mu - w_a * u_a + da * du_a)
        alpha = STEP_TO_BOUNDARY * step_length(step)
        ds, da, db, dz_s, du_s, dz_a, du_a = step
        s, a, b = s + alpha * ds, a + alpha * da, b + alpha * db
        z_s, u_s, z_a, u_a = z_s + alpha * dz_s, u_s + alpha * du_s, z_a + alpha * dz_a, u_a + alpha * du_a
        Kbeta = kernel.matvec(s - a)  # recomputed, not updated, so rounding does not accumulate
    return IPMResult(s - a, b, max_iter, False, residuals)
