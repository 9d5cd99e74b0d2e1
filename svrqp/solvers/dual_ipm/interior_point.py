r"""A structure-exploiting interior-point method for
the ε-SVR dual, and an exact active-set crossover.

**Problem** (S0 eq. 6 in the stacked variables of :mod:`svrqp.formulations.epsilon_svr`,
:math:`\beta = \alpha^* - \alpha`):

.. math::

    \min_{\alpha, \alpha^*}\ \tfrac12 \beta^\top K \beta
    + \varepsilon \mathbf 1^\top(\alpha + \alpha^*)
    - y^\top \beta \quad\text{s.t.}\quad \mathbf
      1^\top\beta = 0,\quad 0 \le \alpha, \alpha^* \le C .

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

    (K + D^{-1})\,\Delta\beta + \Delta b\,\mathbf 1 = D^{-1} h, \qquad \mathbf 1^\top \Delta\beta =
    -r_e, \qquad h = g^*/\Theta^* - g/\Theta ,

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
from typing import NamedTuple

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
    :math:`\\max(\\lVert r\\rVert_\\infty, \\lVert r^*\\rVert_\\infty)`
    and complementarity gap at the last iterate.
    """

    beta: NDArray[np.float64]
    intercept: float
    iterations: int
    converged: bool
    residuals: dict[str, float] = field(default_factory=dict)


def check_inputs(y: NDArray[np.float64], C: float, epsilon: float, n: int) -> None:
    """Raise :class:`ProblemError` unless C, ε and y are valid
    (:func:`~svrqp.formulations.epsilon_svr.check_parameters`) and y has length n."""
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
    """Mehrotra predictor–corrector on the stacked ε-SVR
    dual through the reduced system (module docstring).

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
    y = np.asarray(y, dtype=float)
    check_inputs(y, C, epsilon, kernel.n)
    point = _starting_point(y, C, epsilon)
    scale = 1.0 + float(np.max(np.abs(y)))
    residuals: dict[str, float] = {}
    for iteration in range(1, max_iter + 1):
        state = _residuals(point, y, epsilon, scale)
        residuals = state.relative
        if max(residuals.values()) <= tol:
            return IPMResult(point.s - point.a, point.b, iteration - 1, True, residuals)
        newton = _NewtonSystem(kernel, point, state)
        point = point.moved(_predictor_corrector(newton), kernel)
    return IPMResult(point.s - point.a, point.b, max_iter, False, residuals)


@dataclass
class _Point:
    r"""One interior-point iterate: :math:`\alpha^*` (``s``), :math:`\alpha` (``a``), b, the
    multipliers :math:`z^*, u^*, z, u` of the bounds (``z_s, u_s, z_a, u_a``) and :math:`K\beta`."""

    s: NDArray[np.float64]
    a: NDArray[np.float64]
    b: float
    z_s: NDArray[np.float64]
    u_s: NDArray[np.float64]
    z_a: NDArray[np.float64]
    u_a: NDArray[np.float64]
    Kbeta: NDArray[np.float64]
    C: float
    w_s: NDArray[np.float64] = field(init=False)  #: C - alpha*, the slack of the upper bound
    w_a: NDArray[np.float64] = field(init=False)  #: C - alpha

    def __post_init__(self) -> None:
        self.w_s, self.w_a = self.C - self.s, self.C - self.a

    def moved(self, step: tuple[_Direction, float], kernel: KernelOperator) -> _Point:
        r"""The iterate after ``alpha`` times ``direction``
        (``step``), with :math:`K\beta` recomputed."""
        (ds, da, db, dz_s, du_s, dz_a, du_a), alpha = step
        s, a = self.s + alpha * ds, self.a + alpha * da
        return _Point(s, a, self.b + alpha * db, self.z_s + alpha * dz_s, self.u_s + alpha * du_s,
                      self.z_a + alpha * dz_a, self.u_a + alpha * du_a,
                      # recomputed, not updated, so rounding does not accumulate
                      kernel.matvec(s - a), self.C)


def _starting_point(y: NDArray[np.float64], C: float, epsilon: float) -> _Point:
    """The centre of the box, with the dual residual at β = 0, b = 0 split into positive parts."""
    n = y.size
    g_s, g_a = epsilon - y, epsilon + y  # the dual residuals at beta = 0, b = 0
    return _Point(np.full(n, 0.5 * C), np.full(n, 0.5 * C), 0.0,
                  np.maximum(g_s, 0.0) + 1.0, np.maximum(-g_s, 0.0) + 1.0,
                  np.maximum(g_a, 0.0) + 1.0, np.maximum(-g_a, 0.0) + 1.0, np.zeros(n), C)


def _mean_complementarity(primal: tuple[NDArray, ...], dual: tuple[NDArray, ...]) -> float:
    r""":math:`\mu`: the mean of the four complementarity products, primal ``(s, w_s, a, w_a)``
    against dual ``(z_s, u_s, z_a, u_a)``."""
    (s, w_s, a, w_a), (z_s, u_s, z_a, u_a) = primal, dual
    return float(s @ z_s + w_s @ u_s + a @ z_a + w_a @ u_a) / (4 * s.size)


class _Residuals(NamedTuple):
    """The optimality conditions at an iterate (module docstring) and their relative sizes."""

    r_s: NDArray[np.float64]  #: r*
    r_a: NDArray[np.float64]  #: r
    r_e: float  #: 1^T beta
    mu: float  #: mean complementarity
    relative: dict[str, float]  #: primal_rel, dual_rel, gap_rel


def _residuals(point: _Point, y: NDArray[np.float64], epsilon: float, scale: float) -> _Residuals:
    r""":math:`r^*, r, r_e` and :math:`\mu` at ``point``; ``scale`` is :math:`1 + \max|y|`."""
    s, a, b, Kbeta, C, n = point.s, point.a, point.b, point.Kbeta, point.C, point.s.size
    beta = s - a
    r_s = Kbeta + b + epsilon - y - point.z_s + point.u_s
    r_a = -Kbeta - b + epsilon + y - point.z_a + point.u_a
    r_e = float(beta.sum())
    mu = _mean_complementarity((s, point.w_s, a, point.w_a),
                               (point.z_s, point.u_s, point.z_a, point.u_a))
    objective = 0.5 * float(beta @ Kbeta) + epsilon * float(a.sum() + s.sum()) - float(y @ beta)
    relative = {
        "primal_rel": abs(r_e) / (1.0 + n * C),
        "dual_rel": max(float(np.max(np.abs(r_s))), float(np.max(np.abs(r_a)))) / scale,
        "gap_rel": 4 * n * mu / (1.0 + abs(objective)),
    }
    return _Residuals(r_s, r_a, r_e, mu, relative)


class _Direction(NamedTuple):
    """A Newton direction for every variable of :class:`_Point`."""

    ds: NDArray[np.float64]
    da: NDArray[np.float64]
    db: float
    dz_s: NDArray[np.float64]
    du_s: NDArray[np.float64]
    dz_a: NDArray[np.float64]
    du_a: NDArray[np.float64]


class _NewtonSystem:
    r"""One iteration's reduced system
    :math:`(K + D^{-1})\Delta\beta + \Delta b\mathbf 1 = D^{-1}h`, factorised
    once for the predictor and the corrector (module docstring)."""

    def __init__(self, kernel: KernelOperator, point: _Point, residuals: _Residuals) -> None:
        self.point, self.residuals = point, residuals
        self.theta_s = point.z_s / point.s + point.u_s / point.w_s
        self.theta_a = point.z_a / point.a + point.u_a / point.w_a
        self.d = 1.0 / self.theta_s + 1.0 / self.theta_a
        self.solve = kernel.shifted_solver(1.0 / self.d)
        self.ones_solution = self.solve(np.ones(point.s.size))

    def direction(self, rz_s: NDArray, ru_s: NDArray, rz_a: NDArray, ru_a: NDArray) -> _Direction:
        """The Newton direction for the complementarity
        right-hand sides ``rz_s, ru_s, rz_a, ru_a``."""
        point, theta_s, theta_a, d = self.point, self.theta_s, self.theta_a, self.d
        s, w_s, a, w_a = point.s, point.w_s, point.a, point.w_a
        rho_s = -rz_s / s + ru_s / w_s
        rho_a = -rz_a / a + ru_a / w_a
        g_s, g_a = -self.residuals.r_s - rho_s, -self.residuals.r_a - rho_a
        h = g_s / theta_s - g_a / theta_a
        p = self.solve(h / d)
        db = (p.sum() + self.residuals.r_e) / self.ones_solution.sum()
        dbeta = p - db * self.ones_solution
        t = (h - dbeta) / d  # = K dbeta + db, read off the reduced system
        ds, da = (g_s - t) / theta_s, (g_a + t) / theta_a
        return _Direction(ds, da, db, (rz_s - point.z_s * ds) / s, (ru_s + point.u_s * ds) / w_s,
                          (rz_a - point.z_a * da) / a, (ru_a + point.u_a * da) / w_a)


def _step_length(point: _Point, step: _Direction) -> float:
    """Largest step in [0, 1] that keeps every bound slack and multiplier non-negative."""
    ds, da, _, dz_s, du_s, dz_a, du_a = step
    return min(_max_step(point.s, ds), _max_step(point.w_s, -ds), _max_step(point.a, da),
               _max_step(point.w_a, -da),
               _max_step(point.z_s, dz_s), _max_step(point.u_s, du_s), _max_step(point.z_a, dz_a),
               _max_step(point.u_a, du_a))


def _predictor_corrector(newton: _NewtonSystem) -> tuple[_Direction, float]:
    r"""Mehrotra's step: the affine direction sets the centring :math:`\sigma\mu`, the corrector
    adds it and the second-order term; returns the direction and its damped length."""
    point = newton.point
    s, w_s, a, w_a = point.s, point.w_s, point.a, point.w_a
    z_s, u_s, z_a, u_a = point.z_s, point.u_s, point.z_a, point.u_a
    affine = newton.direction(-s * z_s, -w_s * u_s, -a * z_a, -w_a * u_a)
    alpha = _step_length(point, affine)
    ds, da, _, dz_s, du_s, dz_a, du_a = affine
    mu_affine = _mean_complementarity((s + alpha * ds, w_s - alpha * ds, a + alpha * da,
                                       w_a - alpha * da),
                                      (z_s + alpha * dz_s, u_s + alpha * du_s, z_a + alpha * dz_a,
                                       u_a + alpha * du_a))
    mu = newton.residuals.mu
    sigma_mu = (mu_affine / mu) ** 3 * mu
    step = newton.direction(sigma_mu - s * z_s - ds * dz_s, sigma_mu - w_s * u_s + ds * du_s,
                            sigma_mu - a * z_a - da * dz_a, sigma_mu - w_a * u_a + da * du_a)
    return step, STEP_TO_BOUNDARY * _step_length(point, step)
