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

**Crossover** (active-set steps started at the interior point). Each coefficient has a state:
at :math:`-C`, free negative, zero, free positive, at :math:`+C`. For the free set :math:`F` with
signs :math:`s_F` the optimum solves (cf. ``epsilon_svr.polish``)

.. math::

    K_{FF}\beta_F + b\mathbf 1 = y_F - \varepsilon s_F - K_{F,\bar F}\beta_{\bar F},
    \qquad \mathbf 1^\top \beta_F = -\mathbf 1^\top \beta_{\bar F} ;

and the residuals :math:`\rho = y - K\beta - b` free every fixed coefficient that violates its KKT
condition (a zero with :math:`|\rho_i| > \varepsilon`, a bound with :math:`\rho` on the wrong side of
:math:`\pm\varepsilon`). The primal–dual active-set method (Hintermüller, Ito & Kunisch 2002) also
moves every free coefficient whose solution changed sign or left the box, all at once: a few steps
from a good start, without a guarantee. The feasible active-set method instead steps towards the
free-set solution only as far as signs and box allow, fixing the coefficient that blocks: while
the free-set systems are nonsingular the objective never increases, so it cannot cycle. A
singular free-set system (coinciding inputs, or a linear kernel with more free points than
features plus one) is either consistent — many optimal :math:`\beta`, the least-squares one is
taken — or inconsistent: coinciding inputs with different targets cannot all sit on the tube
edge, the free-set objective then falls without bound along a null-space direction of the
bordered system, and the feasible method moves along it until a coefficient blocks. When no
state changes and every free coefficient sits on its tube edge, every KKT condition holds to
rounding; when the step limit is reached the caller keeps the interior-point solution.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError, SingularSystemError
from svrqp.formulations.epsilon_svr import check_parameters

#: Fraction of the distance to the boundary that one interior-point step may cover.
STEP_TO_BOUNDARY = 0.995

#: A coefficient within this fraction of C of zero or of a bound starts the crossover in that state.
CROSSOVER_THRESHOLD = 1e-6


class DenseKernel:
    """An explicit Gram matrix: products by BLAS, Newton systems by dense Cholesky."""

    def __init__(self, K: NDArray[np.float64]) -> None:
        self.K = K
        self._workspace = np.empty_like(K, order="F")  # reused: fresh n×n allocations cost page faults

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.K.shape[0]

    def matvec(self, v: NDArray[np.float64]) -> NDArray[np.float64]:
        """:math:`K v`."""
        return self.K @ v

    def shifted_solver(self, shift: NDArray[np.float64]) -> Callable[[NDArray], NDArray]:
        """A solver of :math:`(K + \\operatorname{diag}(\\text{shift}))\\,x = \\text{rhs}`."""
        M = self._workspace
        np.copyto(M, self.K)
        M.flat[:: self.n + 1] += shift
        try:
            factor = scipy.linalg.cho_factor(M, lower=True, overwrite_a=True, check_finite=False)
        except np.linalg.LinAlgError:
            raise SingularSystemError("K + D^-1 is not positive definite: is the kernel PSD?") from None
        return lambda rhs: scipy.linalg.cho_solve(factor, rhs, check_finite=False)


class FactoredKernel:
    """A factored kernel :math:`K = LL^\\top` (``L`` of shape ``(n, r)``): Woodbury solves in :math:`O(nr^2)`."""

    def __init__(self, L: NDArray[np.float64]) -> None:
        self.L = L

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.L.shape[0]

    def matvec(self, v: NDArray[np.float64]) -> NDArray[np.float64]:
        """:math:`L (L^\\top v)`."""
        return self.L @ (self.L.T @ v)

    def shifted_solver(self, shift: NDArray[np.float64]) -> Callable[[NDArray], NDArray]:
        """A solver of :math:`(LL^\\top + \\operatorname{diag}(\\text{shift}))\\,x = \\text{rhs}` (Woodbury)."""
        d = 1.0 / shift
        # I + L^T D L as the Gram matrix of D^{1/2} L (lower triangle; no n×r product with D kept)
        core = scipy.linalg.blas.dsyrk(1.0, (self.L * np.sqrt(d)[:, None]).T, trans=0, lower=1)
        core.flat[:: core.shape[0] + 1] += 1.0
        try:
            factor = scipy.linalg.cho_factor(core, lower=True, overwrite_a=True, check_finite=False)
        except np.linalg.LinAlgError:
            raise SingularSystemError("I + L^T D L is not positive definite") from None

        def solve(rhs: NDArray) -> NDArray:
            Drhs = rhs * d
            return Drhs - d * (self.L @ scipy.linalg.cho_solve(factor, self.L.T @ Drhs, check_finite=False))

        return solve


KernelOperator = DenseKernel | FactoredKernel


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


@dataclass
class CrossoverResult:
    """Outcome of :func:`crossover`: the coefficients, bias, steps taken and whether every KKT condition holds."""

    beta: NDArray[np.float64]
    intercept: float
    steps: int
    exact: bool
    free: int
    Kbeta: NDArray[np.float64] | None = None  # K beta from the final (fresh) bounded term, when exact


def _states(beta: NDArray[np.float64], C: float, threshold: float) -> NDArray[np.int8]:
    """-2: at -C, -1: free negative, 0: zero, 1: free positive, 2: at +C."""
    states = np.sign(beta).astype(np.int8)
    states[np.abs(beta) <= threshold * C] = 0
    states[beta >= C * (1 - threshold)] = 2
    states[beta <= -C * (1 - threshold)] = -2
    return states


def crossover(columns: Callable[[NDArray[np.intp]], NDArray[np.float64]], y: NDArray[np.float64], C: float,
              epsilon: float, beta: NDArray[np.float64], *,
              products: Callable[[NDArray[np.intp], NDArray[np.float64]], NDArray[np.float64]] | None = None,
              threshold: float = CROSSOVER_THRESHOLD, kkt_tol: float = 1e-9, max_steps: int = 200,
              fast_steps: int = 8) -> CrossoverResult:
    """Active-set steps from an approximate ``beta`` to the exact optimum (module docstring).

    First up to ``fast_steps`` primal–dual active-set steps (every state updated at once: a few
    steps from a good start, but no guarantee); if they do not settle, the feasible active-set
    method restarts from ``beta`` (one blocking coefficient at a time, objective never increasing).

    Parameters
    ----------
    columns
        ``columns(idx)`` returns the exact kernel columns :math:`K_{:, idx}` (shape ``(n, len(idx))``),
        so only the columns of support vectors are ever formed.
    y, C, epsilon
        Targets and SVR parameters.
    beta
        Starting coefficients (an interior-point solution): states within ``threshold``·C of a bound
        or of zero are taken as active.
    products
        ``products(idx, v)`` returns :math:`K_{:, idx} v`; defaults to ``columns(idx) @ v``. A linear
        kernel passes :math:`X (X_{idx}^\\top v)`, so the many bounded columns are never formed.
    kkt_tol
        Slack on the tube conditions, relative to :math:`1 + \\max|y|`.
    max_steps
        Limit on the feasible active-set steps; ``exact`` is false when it is reached.
    fast_steps
        Limit on the primal–dual active-set steps tried first.
    """
    beta = np.asarray(beta, dtype=float)
    C = float(C)  # an integer C times the int8 states would overflow
    slack = kkt_tol * (1.0 + float(np.max(np.abs(y))))
    kernel = _KernelAccess(columns, products or (lambda idx, v: columns(idx) @ v), y.size)
    fast = _primal_dual_active_set(kernel, y, C, epsilon, _states(beta, C, threshold), slack, fast_steps)
    if fast.exact:
        return fast
    careful = _feasible_active_set(kernel, y, C, epsilon, beta, _states(beta, C, threshold), slack, max_steps)
    careful.steps += fast.steps
    return careful


class _KernelAccess:
    """Kernel columns for the crossover and the bounded term :math:`K_{:,B}\\beta_B`, kept up to date.

    Each active-set step changes few states, so the bounded term changes by a few columns:
    updating it by the change only makes a step cost :math:`O(n\\,(|F| + \\Delta))` kernel entries
    instead of :math:`O(n\\,(|F| + |B|))`. Columns are served by ``columns`` (a
    :class:`svrqp.kernel_columns.KernelColumns` caches them; a dense K is indexed).
    """

    def __init__(self, columns: Callable[[NDArray[np.intp]], NDArray[np.float64]],
                 products: Callable[[NDArray[np.intp], NDArray[np.float64]], NDArray[np.float64]], n: int) -> None:
        self.free_columns, self._products, self.n = columns, products, n
        self._fixed = np.zeros(n)  # the bounded values summed in bounded_term
        self.bounded_term = np.zeros(n)
        self._from_scratch = True  # bounded_term is one product over every bounded column

    def update_bounded(self, fixed: NDArray[np.float64], *, fresh: bool = False) -> NDArray[np.float64]:
        """:math:`K \\cdot` ``fixed`` (``fixed`` is ±C on the bounded set, 0 elsewhere), updated by the change only.

        ``fresh`` recomputes it from all bounded columns, so the final KKT check carries no
        accumulated rounding; a term that is still the single product it was first computed as
        is already fresh and is kept.
        """
        if fresh and not self._from_scratch:
            self._fixed, self.bounded_term = np.zeros(self.n), np.zeros(self.n)
        changed = np.flatnonzero(fixed != self._fixed)
        if changed.size:
            self._from_scratch = not self._fixed.any()
            self.bounded_term = self.bounded_term + self._products(changed, fixed[changed] - self._fixed[changed])
            self._fixed = fixed.copy()
        return self.bounded_term


def _free_set_solution(kernel: _KernelAccess, y, C, epsilon, states, fresh=False):
    """The equality-constrained optimum on the free set (module docstring), K_{:,F}, K_{:,bounded} beta_bounded,
    and the direction in which the free-set objective is unbounded below (None when it is not)."""
    free = np.flatnonzero(np.abs(states) == 1)
    fixed = np.where(np.abs(states) == 2, np.sign(states) * C, 0.0)
    K_free = kernel.free_columns(free)
    bounded_term = kernel.update_bounded(fixed, fresh=fresh)
    rhs = y[free] - epsilon * states[free] - bounded_term[free]
    target, b, unbounded = _bordered_solve(K_free[free], rhs, -float(fixed.sum()))
    return free, fixed, K_free, bounded_term, target, b, unbounded


#: At most this many KKT violators (the worst ones) enter the free set in one step, beyond the
#: size of the free set itself: a bias far off early on can flag thousands, and a free set of
#: thousands costs O(n·|F|) kernel entries and an O(|F|³) solve for a step that is soon undone.
ENTERING_PER_STEP = 64


def _kkt_entering(rho: NDArray[np.float64], states: NDArray[np.int8], epsilon: float, slack: float):
    """The worst fixed coefficients whose residual violates their KKT condition: (to free positive, to free negative).

    A zero with :math:`|\\rho| > \\varepsilon` or a bound with :math:`\\rho` on the wrong side of
    :math:`\\pm\\varepsilon` violates by that distance; at most ``ENTERING_PER_STEP`` plus the number
    of free coefficients enter at once.
    """
    zero = states == 0
    violation_positive = np.where(zero, rho - epsilon, np.where(states == 2, epsilon - rho, -np.inf))
    violation_negative = np.where(zero, -rho - epsilon, np.where(states == -2, rho + epsilon, -np.inf))
    positive, negative = violation_positive > slack, violation_negative > slack
    limit = ENTERING_PER_STEP + int(np.sum(np.abs(states) == 1))
    if positive.sum() + negative.sum() > limit:
        worst = np.maximum(violation_positive, violation_negative)
        kept = np.zeros(rho.size, dtype=bool)
        kept[np.argpartition(-worst, limit)[:limit]] = True
        positive, negative = positive & kept, negative & kept
    return positive, negative


def _residuals(y, K_free, beta_free, bounded_term, states, epsilon, b, free):
    rho = y - K_free @ beta_free - bounded_term
    if free.size == 0:
        b = _midpoint_bias(rho, states, epsilon)
    return rho - b, b


def _primal_dual_active_set(kernel, y, C, epsilon, states, slack, max_steps) -> CrossoverResult:
    """Hintermüller–Ito–Kunisch: solve on the free set, then update every state from the result.

    Gives up as soon as the number of state changes stops shrinking: away from the optimum the
    method can swing large sets back and forth, and each such step costs a large free-set solve.
    """
    beta, b, fresh, previous_changes = np.zeros(y.size), 0.0, False, y.size + 1
    for step in range(1, max_steps + 1):
        free, fixed, K_free, bounded_term, target, b, unbounded = _free_set_solution(kernel, y, C, epsilon, states,
                                                                                     fresh)
        if unbounded is not None:  # no free-set optimum to jump to: the feasible method moves along it
            return CrossoverResult(beta, b, step, False, int(free.size))
        beta = fixed.copy()
        beta[free] = target
        rho, b = _residuals(y, K_free, target, bounded_term, states, epsilon, b, free)
        new_states = states.copy()
        positive, negative = states == 1, states == -1
        new_states[(positive & (beta <= 0)) | (negative & (beta >= 0))] = 0
        new_states[positive & (beta > C)] = 2
        new_states[negative & (beta < -C)] = -2
        entering_positive, entering_negative = _kkt_entering(rho, states, epsilon, slack)
        new_states[entering_positive] = 1
        new_states[entering_negative] = -1
        if np.array_equal(new_states, states):
            if fresh or not _balanced(beta, C):
                exact = _balanced(beta, C) and _free_equalities_hold(rho, states, epsilon, slack)
                return CrossoverResult(beta, b, step, exact, int(free.size), K_free @ target + bounded_term)
            fresh = True  # confirm once with the bounded term recomputed from scratch
            continue
        changes = int(np.count_nonzero(new_states != states))
        if changes >= previous_changes:
            return CrossoverResult(beta, b, step, False, int(free.size))
        states, fresh, previous_changes = new_states, False, changes
    return CrossoverResult(beta, b, max_steps, False, int(np.sum(np.abs(states) == 1)))


def _feasible_active_set(kernel, y, C, epsilon, beta, states, slack, max_steps) -> CrossoverResult:
    """Move towards the free-set optimum as far as signs and box allow; free KKT violators after a full step."""
    current = np.where(np.abs(states) == 2, np.sign(states) * C, np.where(states == 0, 0.0, beta))
    b, fresh = 0.0, False
    for step in range(1, max_steps + 1):
        free, _, K_free, bounded_term, target, b, unbounded = _free_set_solution(kernel, y, C, epsilon, states, fresh)
        if unbounded is None:
            direction = target - current[free]
        else:  # scaled so that the largest coordinate would cross the whole box: a coefficient must block
            direction = unbounded * (2.0 * C / np.max(np.abs(unbounded)))
        length, blocking = _step_to_sign_or_box(current[free], direction, states[free], C)
        current[free] += length * direction
        if length < 1.0:
            hit = free[blocking]
            at_bound = np.abs(current[hit]) >= 0.5 * C
            states[hit] = np.where(at_bound, 2 * states[hit], 0)
            current[hit] = np.where(at_bound, np.sign(states[hit]) * C, 0.0)
            fresh = False
            continue
        rho, b = _residuals(y, K_free, current[free], bounded_term, states, epsilon, b, free)
        entering_positive, entering_negative = _kkt_entering(rho, states, epsilon, slack)
        if not (entering_positive.any() or entering_negative.any()):
            if fresh or not _balanced(current, C):
                exact = _balanced(current, C) and _free_equalities_hold(rho, states, epsilon, slack)
                return CrossoverResult(current, b, step, exact, int(free.size), K_free @ current[free] + bounded_term)
            fresh = True  # confirm once with the bounded term recomputed from scratch
            continue
        states[entering_positive] = 1
        states[entering_negative] = -1
        fresh = False
    return CrossoverResult(current, b, max_steps, False, int(np.sum(np.abs(states) == 1)))


def _balanced(beta: NDArray[np.float64], C: float) -> bool:
    """Whether :math:`\\mathbf 1^\\top\\beta = 0` to rounding: with no free coefficient the free-set
    solve cannot restore it, and states that admit no KKT violation are then not an optimum."""
    return abs(float(beta.sum())) <= BALANCE_TOL * C * beta.size


#: Relative tolerance of the equality :math:`\mathbf 1^\top\beta = 0` in the crossover's final check.
BALANCE_TOL = 1e-9


def _free_equalities_hold(residual: NDArray[np.float64], states: NDArray[np.int8], epsilon: float,
                          slack: float) -> bool:
    """Whether every free coefficient sits on its tube edge, :math:`y_i - f(x_i) = \\varepsilon s_i`.

    The free-set solve makes this hold unless its system was inconsistent (coinciding inputs with
    different targets both free), which the final check must not take on trust.
    """
    free = np.abs(states) == 1
    return bool(np.all(np.abs(residual[free] - epsilon * states[free]) <= slack))


def _step_to_sign_or_box(x: NDArray[np.float64], direction: NDArray[np.float64], signs: NDArray[np.int8],
                         C: float) -> tuple[float, NDArray[np.bool_]]:
    """Largest step in [0, 1] keeping ``s·x`` in [0, C] for each sign s, and which coordinates block it."""
    toward = signs * direction  # rate of change of s·x
    position = signs * x
    with np.errstate(divide="ignore", invalid="ignore"):
        limits = np.where(toward < 0, position / -toward, np.where(toward > 0, (C - position) / toward, np.inf))
    limits = np.maximum(limits, 0.0)
    length = float(min(1.0, np.min(limits, initial=np.inf)))
    return length, limits <= length if length < 1.0 else np.zeros(x.size, dtype=bool)


def _midpoint_bias(rho: NDArray[np.float64], states: NDArray[np.int8], epsilon: float) -> float:
    """With no free coefficient, b is the midpoint of the interval the KKT conditions allow (libsvm's rule)."""
    zero, upper, lower = states == 0, states == 2, states == -2
    low = np.concatenate([rho[zero] - epsilon, rho[lower] + epsilon])
    high = np.concatenate([rho[zero] + epsilon, rho[upper] - epsilon])
    bounds = [float(low.max()) if low.size else None, float(high.min()) if high.size else None]
    finite = [value for value in bounds if value is not None]
    return float(np.mean(finite)) if finite else 0.0


#: Below this ratio of the smallest to the largest squared Cholesky pivot, K_FF counts as singular.
SINGULAR_PIVOT_RATIO = 1e-12

#: A singular free-set system whose least-squares residual exceeds this (relative to its right-hand
#: side) is inconsistent: its objective has no minimum on the free set.
INCONSISTENT_TOL = 1e-9


def _bordered_solve(K_FF: NDArray[np.float64], rhs: NDArray[np.float64], total: float
                    ) -> tuple[NDArray[np.float64], float, NDArray[np.float64] | None]:
    """Solve :math:`K_{FF}x + b\\mathbf 1 = \\text{rhs},\\ \\mathbf 1^\\top x = \\text{total}`: ``(x, b, unbounded)``.

    Cholesky of :math:`K_{FF}` and the Schur complement for b. When :math:`K_{FF}` is singular
    (a linear kernel with more free points than features, or coinciding points) the least-squares
    solution is taken. If the system is consistent it is one of its many exact solutions and
    ``unbounded`` is None. If not (coinciding inputs with different targets), the residual
    :math:`w = v - Mz` of the bordered system :math:`Mz = v` lies in the null space of the
    symmetric :math:`M`, and its first :math:`m` entries :math:`d` satisfy
    :math:`K_{FF}d \\propto \\mathbf 1,\\ \\mathbf 1^\\top d = 0`: along :math:`d` the free-set
    objective :math:`\\tfrac12 x^\\top K_{FF}x - \\text{rhs}^\\top x` falls at the constant rate
    :math:`\\|w\\|^2` with no minimum, and ``unbounded`` is :math:`d`.
    """
    m = rhs.size
    if m == 0:
        return np.zeros(0), 0.0, None  # no free SV: the caller sets b by the midpoint rule
    try:
        factor = scipy.linalg.cho_factor(K_FF, lower=True, check_finite=False)
        pivots = np.abs(np.diag(factor[0])) ** 2
        if pivots.min() > SINGULAR_PIVOT_RATIO * pivots.max():
            solution = scipy.linalg.cho_solve(factor, np.column_stack([rhs, np.ones(m)]), check_finite=False)
            mu, nu = solution[:, 0], solution[:, 1]
            b = (mu.sum() - total) / nu.sum()
            return mu - b * nu, float(b), None
    except np.linalg.LinAlgError:
        pass
    M = np.zeros((m + 1, m + 1))
    M[:m, :m] = K_FF
    M[:m, m] = M[m, :m] = 1.0
    v = np.concatenate([rhs, [total]])
    x = scipy.linalg.lstsq(M, v, cond=SINGULAR_PIVOT_RATIO, check_finite=False,
                         lapack_driver="gelsy")[0]  # QR with column pivoting: several times faster than the SVD
    w = v - M @ x
    consistent = np.max(np.abs(w)) <= INCONSISTENT_TOL * (1.0 + np.max(np.abs(v)))
    return x[:m], float(x[m]), None if consistent else w[:m]


@dataclass
class ExactFit:
    """The exact ε-SVR dual solution found by :func:`solve_exact`, with where the time went."""

    beta: NDArray[np.float64]
    intercept: float
    ipm: IPMResult
    crossover: CrossoverResult
    times_s: dict[str, float]
    low_rank: bool = False  # whether the interior point ran on a low-rank factor (no Gram matrix formed)


def solve_exact(K: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float, *,
                tol: float = 1e-8, max_iter: int = 100) -> ExactFit:
    """Interior point on the reduced dense system, then the active-set crossover to the exact optimum.

    When the crossover does not settle (``crossover.exact`` false) the interior-point solution is
    returned; its certificates say how accurate it is.
    """
    return _interior_point_then_crossover(DenseKernel(K), lambda idx: K[:, idx], y, C, epsilon, tol, max_iter)


#: The interior point behind a crossover stops at this relative accuracy (or the requested one, if
#: looser): the crossover needs the active set, not the optimum, and states read with the
#: threshold :math:`\\sqrt{\\text{tol}}` are already right there; it saves about a third of the
#: iterations. When the crossover does not settle, the interior point is run again to ``tol``.
IDENTIFICATION_TOL = 1e-4


def _interior_point_then_crossover(kernel: KernelOperator, columns, y, C, epsilon, tol, max_iter) -> ExactFit:
    times_s = {"ipm_s": 0.0, "crossover_s": 0.0}
    for ipm_tol in dict.fromkeys([max(tol, IDENTIFICATION_TOL), tol]):  # the loose run first
        start = time.perf_counter()
        ipm = interior_point(kernel, y, C, epsilon, tol=ipm_tol, max_iter=max_iter)
        middle = time.perf_counter()
        result = crossover(columns, y, C, epsilon, ipm.beta, threshold=max(CROSSOVER_THRESHOLD, np.sqrt(ipm_tol)))
        times_s["ipm_s"] += middle - start
        times_s["crossover_s"] += time.perf_counter() - middle
        if result.exact:
            break
    beta, b = (result.beta, result.intercept) if result.exact else (ipm.beta, ipm.intercept)
    return ExactFit(beta, b, ipm, result, times_s)


def solve_exact_from_data(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float, *,
                          kernel: str = "rbf", gamma: float = 1.0, degree: int = 3, coef0: float = 0.0,
                          tol: float = 1e-8, factor_tol: float = 3e-5, max_rank: int | None = None,
                          max_iter: int = 100, K: NDArray[np.float64] | None = None) -> ExactFit:
    """The fastest exact path: a low-rank interior point when the kernel allows it, the dense one otherwise.

    A pivoted Cholesky factor of rank at most ``max_rank`` (default ``n // 8``) is tried first;
    if its relative trace error reaches ``factor_tol``, the interior point runs on
    :math:`LL^\top` in :math:`O(nr^2)` per iteration and the crossover, which uses exact kernel
    columns of the support vectors only, turns its solution into the exact optimum: the factor
    only guides the search (a coarser one means more crossover steps, not another answer). When
    the factor does not reach ``factor_tol`` or the crossover does not settle, the full Gram
    matrix is formed (or ``K`` used, when the caller already holds it) and :func:`solve_exact`
    runs. ``times_s`` adds the factorisation (``factor_s``) and Gram (``gram_s``) times.
    """
    from svrqp.formulations.low_rank import pivoted_cholesky
    from svrqp.kernel_columns import KernelColumns
    from svrqp.kernels import gram

    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    n = X.shape[0]
    _check(y, C, epsilon, n)
    parameters = {"kernel": kernel, "gamma": gamma, "degree": degree, "coef0": coef0}
    start = time.perf_counter()
    columns = KernelColumns(X, **parameters)
    factor = pivoted_cholesky(columns, max_rank=max_rank or max(1, n // 8), tol=factor_tol, give_up=True)
    factor_s = time.perf_counter() - start
    if factor.relative_trace_error <= factor_tol:
        fit = _interior_point_then_crossover(FactoredKernel(factor.L), columns, y, C, epsilon, tol, max_iter)
        if fit.crossover.exact:
            fit.times_s.update(factor_s=factor_s, gram_s=0.0)
            fit.low_rank = True
            return fit
    start = time.perf_counter()
    K = gram(X, **parameters) if K is None else K
    gram_s = time.perf_counter() - start
    fit = solve_exact(K, y, C, epsilon, tol=tol, max_iter=max_iter)
    fit.times_s.update(factor_s=factor_s, gram_s=gram_s)
    return fit
