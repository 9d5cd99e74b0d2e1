r"""The exact active-set crossover from an interior-point solution of the ε-SVR dual.

The problem and its optimality conditions are those of :mod:`svrqp.solvers.dual_ipm.interior_point`.

**Crossover** (active-set steps started at the interior point). Each coefficient has a state:
at :math:`-C`, free negative, zero, free positive, at :math:`+C`. For the free set :math:`F` with
signs :math:`s_F` the optimum solves (cf. ``epsilon_svr.polish``)

.. math::

    K_{FF}\beta_F + b\mathbf 1 = y_F - \varepsilon s_F - K_{F,\bar F}\beta_{\bar F},
    \qquad \mathbf 1^\top \beta_F = -\mathbf 1^\top \beta_{\bar F} ;

and the residuals :math:`\rho = y - K\beta - b` free every fixed coefficient that violates its KKT
condition (a zero with :math:`|\rho_i| > \varepsilon`, a bound with :math:`\rho` on the wrong side
of :math:`\pm\varepsilon`). The primal–dual active-set method (Hintermüller, Ito & Kunisch 2002)
also moves every free coefficient whose solution changed sign or left the box, all at once: a few
steps from a good start, without a guarantee. The feasible active-set method instead steps towards
the free-set solution only as far as signs and box allow, fixing the coefficient that blocks: while
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

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.linalg.lapack
from numpy.typing import NDArray

from svrqp.formulations import epsilon_svr_certificate as certificate

#: A coefficient within this fraction of C of zero or of a bound starts the crossover in that state.
CROSSOVER_THRESHOLD = 1e-6


@dataclass(frozen=True)
class CrossoverSettings:
    """How far :func:`crossover` goes (see its docstring)."""

    #: fraction of C within which a start coefficient is at zero or a bound
    threshold: float = CROSSOVER_THRESHOLD
    kkt_tol: float = 1e-9  #: slack on the tube conditions, relative to 1 + max|y|
    #: limit on the feasible active-set steps; ``exact`` is false when it is reached
    max_steps: int = 200
    fast_steps: int = 8  #: limit on the primal–dual active-set steps tried first


class DenseColumns:
    """The ``columns`` of :func:`crossover` for a Gram matrix the caller already holds:
    ``K[:, idx]``, and ``block(rows, idx)`` = ``K[rows, idx]`` (:meth:`_KernelAccess.free_block`).
    """

    def __init__(self, K: NDArray[np.float64]) -> None:
        self.K = K

    def __call__(self, idx: NDArray[np.intp]) -> NDArray[np.float64]:
        return self.K[:, idx]

    def block(self, rows: NDArray[np.intp], idx: NDArray[np.intp]) -> NDArray[np.float64]:
        return self.K[rows[:, None], idx]  # np.ix_'s checks cost more than a small gather


class LinearColumns:
    r"""The ``columns`` of :func:`crossover` for the linear kernel :math:`K = XX^\top`, from X
    alone: ``products(idx, v)`` = :math:`X (X_{idx}^\top v)`, so the many bounded columns of a
    primal solve's crossover are never formed."""

    def __init__(self, X: NDArray[np.float64]) -> None:
        self.X = X

    def __call__(self, idx: NDArray[np.intp]) -> NDArray[np.float64]:
        return self.X @ self.X[idx].T

    def block(self, rows: NDArray[np.intp], idx: NDArray[np.intp]) -> NDArray[np.float64]:
        return self.X[rows] @ self.X[idx].T

    def products(self, idx: NDArray[np.intp], v: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.X @ (self.X[idx].T @ v)


@dataclass
class CrossoverResult:
    """Outcome of :func:`crossover`: the coefficients, bias,
    steps taken and whether every KKT condition holds."""

    beta: NDArray[np.float64]
    intercept: float
    steps: int
    exact: bool
    free: int
    # K beta from the final (accurate) bounded term, when exact
    Kbeta: NDArray[np.float64] | None = None


def crossover(columns: Callable[[NDArray[np.intp]], NDArray[np.float64]], y: NDArray[np.float64],
              C: float, epsilon: float, beta: NDArray[np.float64], *,
              settings: CrossoverSettings = CrossoverSettings(),
              kernel_scale: float = 0.0,
              bounded_start: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
              ) -> CrossoverResult:
    """Active-set steps from an approximate ``beta`` to the exact optimum (module docstring).

    First up to ``settings.fast_steps`` primal–dual active-set steps (every state updated at once: a
    few steps from a good start, but no guarantee); if they do not settle, the feasible active-set
    method restarts from ``beta`` (one blocking coefficient at a time, objective never increasing).

    Parameters
    ----------
    columns
        ``columns(idx)`` returns the exact kernel columns :math:`K_{:, idx}` (shape
        ``(n, len(idx))``), so only the columns of support vectors are ever formed. Columns that
        also offer ``block(rows, idx)`` (:class:`DenseColumns`, :class:`LinearColumns`,
        :class:`svrqp.linalg.kernel_columns.KernelColumns`) serve :math:`K_{FF}` from it, and
        those that offer ``products(idx, v)`` = :math:`K_{:, idx} v` (:class:`LinearColumns`,
        ``KernelColumns``: formed in blocks, never cached) the bounded term from it; otherwise
        it is ``columns(idx) @ v``.
    y, C, epsilon
        Targets and SVR parameters.
    beta
        Starting coefficients (an interior-point solution): states within ``settings.threshold``·C
        of a bound or of zero are taken as active
        (:func:`svrqp.formulations.epsilon_svr_certificate.states`).
    settings
        The start threshold, the slack on the tube conditions and the two step limits.
    kernel_scale
        :math:`\\max_i K_{ii}` (0: not known). The slack on the tube conditions then also allows
        the rounding of :math:`K\beta` that the returned model's certificate allows
        (:func:`rounding_slack`): with a linear kernel on inputs of 1e3, the products of 20
        coefficients at C = 10 round by 1e-7 of y, and a slack of 1e-9 never let the crossover
        settle (issue #39, finding 15).
    bounded_start
        ``(v, K v)`` for coefficients ``v`` at ±C or zero, :math:`Kv` formed from scratch by the
        caller (the screened start's coefficients at ±C, held or put there by its loose run:
        :attr:`svrqp.solvers.screening.DecompositionFit.bounded_term`): the bounded term is then
        updated from it by the change only, instead of formed again from every bounded column.
    """
    beta = np.asarray(beta, dtype=float)
    C = float(C)  # an integer C times the int8 states would overflow
    slack = (settings.kkt_tol * (1.0 + float(np.abs(y).max()))
             + rounding_slack(beta, C, kernel_scale))
    kernel = _KernelAccess(columns, y.size)
    if bounded_start is not None:
        kernel.start_from(*bounded_start)
    start = certificate.states(beta, C, settings.threshold)
    fast = _primal_dual_active_set(kernel, y, C, epsilon, start.copy(), slack, settings.fast_steps)
    if fast.exact:
        return fast
    careful = _feasible_active_set(kernel, y, C, epsilon, beta, start, slack, settings.max_steps)
    careful.steps += fast.steps
    return careful


def products_of(columns: Callable[[NDArray[np.intp]], NDArray[np.float64]]
                ) -> Callable[[NDArray[np.intp], NDArray[np.float64]], NDArray[np.float64]]:
    """``products(idx, v)`` = :math:`K_{:, idx} v` of ``columns``: their own where they offer one
    (:func:`crossover`), else ``columns(idx) @ v``."""
    own = getattr(columns, "products", None)
    return own if own is not None else (lambda idx, v: columns(idx) @ v)


def rounding_slack(beta: NDArray[np.float64], C: float, kernel_scale: float) -> float:
    r"""The rounding of :math:`K\beta` at coefficients like ``beta`` (clipped to the box), in the
    units of y: :math:`64\,u\,k \sum_i \min(|\beta_i|, C)` with k = ``kernel_scale``, the
    allowance of :func:`svrqp.formulations.epsilon_svr_certificate.model_certificate` (Higham 2002,
    §3.1: a sum of m products rounds by at most about :math:`m u` times the sum of their sizes)."""
    l1 = float(np.minimum(np.abs(beta), C).sum())
    return certificate.ROUNDING_ULPS * certificate.EPS * kernel_scale * l1


class _KernelAccess:
    r"""Kernel columns for the crossover and the bounded
    term :math:`K_{:,B}\beta_B`, kept up to date.

    Each active-set step changes few states, so the bounded term changes by a few columns:
    updating it by the change only makes a step cost :math:`O(n\,(|F| + \Delta))` kernel entries
    instead of :math:`O(n\,(|F| + |B|))`. Columns are served by ``columns`` (a
    :class:`svrqp.linalg.kernel_columns.KernelColumns` caches them; a dense K is indexed).

    **Rounding of the updates.** A product of m columns carries a rounding error of at most about
    :math:`m\,u\,C\max|K|` per entry (u the unit roundoff; Higham 2002, *Accuracy and Stability
    of Numerical Algorithms*, §3.1), and each update adds its own columns' share plus one rounding
    of the sum. While the columns changed since the last product from scratch number at most the
    columns of that product, the term's error bound is at most about twice a fresh product's, far
    below the crossover's KKT slack: the term is ``accurate`` and the final check uses it as is.
    Past that it is recomputed from all bounded columns before the final check.
    """

    def __init__(self, columns: Callable[[NDArray[np.intp]], NDArray[np.float64]],
                 n: int) -> None:
        self.free_columns, self._products, self.n = columns, products_of(columns), n
        self._block = getattr(columns, "block", None)  # K_FF where the columns serve it
        self._fixed = np.zeros(n)  # the bounded values summed in bounded_term
        self.bounded_term = np.zeros(n)
        self._scratch_columns = 0  # columns of the last product from scratch
        self._changed_columns = 0  # columns changed by updates since then

    def start_from(self, fixed: NDArray[np.float64], product: NDArray[np.float64]) -> None:
        r"""Take ``product`` = :math:`K \cdot` ``fixed``, formed from scratch, as the bounded
        term of the values ``fixed``."""
        self._fixed = np.array(fixed, dtype=float)
        self.bounded_term = np.array(product, dtype=float)
        self._scratch_columns, self._changed_columns = int(np.count_nonzero(fixed)), 0

    def free_block(self, free: NDArray[np.intp]) -> NDArray[np.float64]:
        """:math:`K_{FF}`: from the columns' own ``block(rows, idx)`` where they offer one
        (:meth:`svrqp.linalg.kernel_columns.KernelColumns.block`, :class:`DenseColumns`), which
        gathers :math:`|F|^2` entries instead of the :math:`n|F|` of the whole free columns."""
        return self._block(free, free) if self._block is not None else self.free_columns(free)[free]

    @property
    def accurate(self) -> bool:
        """Whether the bounded term's rounding is within
        about twice a fresh product's (class docstring)."""
        return self._changed_columns <= self._scratch_columns

    def update_bounded(self, fixed: NDArray[np.float64], *,
                       fresh: bool = False) -> NDArray[np.float64]:
        r""":math:`K \cdot` ``fixed`` (``fixed`` is ±C on the
        bounded set, 0 elsewhere), updated by the change only.

        ``fresh`` recomputes it from all bounded columns unless it is ``accurate`` already.
        """
        from_scratch = (fresh and not self.accurate) or not self._fixed.any()
        if from_scratch:  # also drops what updates that cancelled out left behind
            self._fixed, self.bounded_term = np.zeros(self.n), np.zeros(self.n)
        changed = (fixed != self._fixed).nonzero()[0]
        if changed.size:
            self.bounded_term = self.bounded_term + self._products(
                changed, fixed[changed] - self._fixed[changed])
            self._fixed = fixed.copy()
        if from_scratch:
            self._scratch_columns, self._changed_columns = changed.size, 0
        else:
            self._changed_columns += changed.size
        return self.bounded_term


def _free_set_solution(kernel: _KernelAccess, y, C, epsilon, states, fresh=False):
    """The equality-constrained optimum on the free set (module docstring), K_{:,bounded}
    beta_bounded, and the direction in which the free-set objective is unbounded below (None
    when it is not). Only K_FF is read: the whole free columns K_{:,F}, which the residuals of
    every point need, are the caller's to fetch (a blocked step of the feasible method needs none).
    """
    magnitude = np.abs(states)
    free = (magnitude == 1).nonzero()[0]
    fixed = np.where(magnitude == 2, np.sign(states) * C, 0.0)
    bounded_term = kernel.update_bounded(fixed, fresh=fresh)
    rhs = y[free] - epsilon * states[free] - bounded_term[free]
    target, b, unbounded = _bordered_solve(kernel.free_block(free), rhs, -float(fixed.sum()))
    return free, fixed, bounded_term, target, b, unbounded


#: At most this many KKT violators (the worst ones) enter the free set in one step, beyond the
#: size of the free set itself: a bias far off early on can flag thousands, and a free set of
#: thousands costs O(n·|F|) kernel entries and an O(|F|³) solve for a step that is soon undone.
ENTERING_PER_STEP = 64

#: Per state (row ``state + 2``: at −C, free negative, zero, free positive, at +C), the sign that
#: turns :math:`\rho - \varepsilon` into the violation of a coefficient that would enter as free
#: positive (a zero: :math:`\rho - \varepsilon`; at +C: :math:`\varepsilon - \rho`), and
#: :math:`\rho + \varepsilon` into that of one entering as free negative; NaN where a state cannot
#: enter that way. Two gathers and two products replace six ``np.where`` on every step.
_ENTER_POSITIVE = np.array([np.nan, np.nan, 1.0, np.nan, -1.0])
_ENTER_NEGATIVE = np.array([1.0, np.nan, -1.0, np.nan, np.nan])


def _kkt_entering(rho: NDArray[np.float64], states: NDArray[np.int8], epsilon: float, slack: float,
                  free_count: int):
    """The worst fixed coefficients whose residual violates
    their KKT condition: (to free positive, to free negative).

    A zero with :math:`|\\rho| > \\varepsilon` or a bound with :math:`\\rho` on the wrong side of
    :math:`\\pm\\varepsilon` violates by that distance; at most ``ENTERING_PER_STEP`` plus the
    number of free coefficients (``free_count``) enter at once.
    """
    index = states + 2  # the state's row of the sign tables (-2 … 2)
    violation_positive = _ENTER_POSITIVE[index] * (rho - epsilon)
    violation_negative = _ENTER_NEGATIVE[index] * (rho + epsilon)
    positive, negative = violation_positive > slack, violation_negative > slack  # NaN: never
    limit = ENTERING_PER_STEP + free_count
    if np.count_nonzero(positive) + np.count_nonzero(negative) > limit:
        worst = np.fmax(violation_positive, violation_negative)  # NaN where neither can enter
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

    Gives up at the first step that changes no fewer states than the fewest so far: away from the
    optimum the method can swing large sets back and forth, and each such step costs a large
    free-set solve and the kernel columns of every state it changes. (Letting it stall twice before
    giving up saved steps from the screened start at C = 1, but a swing of the free set from 63 to
    190 at C = 10 on the thermal panel generator cost 1.5–2.5× the crossover's time at n = 4000 and
    8000: 84 and 99 ms against 56 and 40 ms, measured.)
    """
    beta, b, fresh, fewest_changes = np.zeros(y.size), 0.0, False, y.size + 1
    for step in range(1, max_steps + 1):
        free, fixed, bounded_term, target, b, unbounded = _free_set_solution(
            kernel, y, C, epsilon, states, fresh)
        # no free-set optimum to jump to: the feasible method moves along it
        if unbounded is not None:
            return CrossoverResult(beta, b, step, False, int(free.size))
        beta = fixed.copy()
        beta[free] = target
        K_free = kernel.free_columns(free)
        rho, b = _residuals(y, K_free, target, bounded_term, states, epsilon, b, free)
        new_states = states.copy()
        moved = states[free] * target  # s·β of each free coefficient of sign s
        new_states[free[moved <= 0.0]] = 0  # it left its sign
        new_states[free[moved > C]] *= 2  # it left the box: at ±C
        entering_positive, entering_negative = _kkt_entering(rho, states, epsilon, slack,
                                                             free.size)
        new_states[entering_positive] = 1
        new_states[entering_negative] = -1
        # array methods, not np.array_equal / np.flatnonzero: a small fit pays their dispatch
        if not (new_states != states).any():
            balanced = _balanced(beta, C)
            if fresh or kernel.accurate or not balanced:
                exact = balanced and _free_equalities_hold(rho, states, free, epsilon, slack)
                return CrossoverResult(beta, b, step, exact, int(free.size),
                                       K_free @ target + bounded_term)
            # confirm once with the bounded term recomputed from scratch (class _KernelAccess)
            fresh = True
            continue
        changes = int(np.count_nonzero(new_states != states))
        if changes >= fewest_changes:
            return CrossoverResult(beta, b, step, False, int(free.size))
        states, fresh, fewest_changes = new_states, False, changes
    return CrossoverResult(beta, b, max_steps, False, int(np.sum(np.abs(states) == 1)))


def _feasible_active_set(kernel, y, C, epsilon, beta, states, slack, max_steps) -> CrossoverResult:
    """Move towards the free-set optimum as far as signs
    and box allow; free KKT violators after a full step."""
    current = np.where(np.abs(states) == 2, np.sign(states) * C, np.where(states == 0, 0.0, beta))
    b, fresh = 0.0, False
    for step in range(1, max_steps + 1):
        free, _, bounded_term, target, b, unbounded = _free_set_solution(
            kernel, y, C, epsilon, states, fresh)
        if unbounded is None:
            direction = target - current[free]
        # scaled so that the largest coordinate would cross the whole box: a coefficient must block
        else:
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
        K_free = kernel.free_columns(free)  # a full step: every point's residual is checked
        rho, b = _residuals(y, K_free, current[free], bounded_term, states, epsilon, b, free)
        entering_positive, entering_negative = _kkt_entering(rho, states, epsilon, slack,
                                                             free.size)
        if not (entering_positive.any() or entering_negative.any()):
            balanced = _balanced(current, C)
            if fresh or kernel.accurate or not balanced:
                exact = balanced and _free_equalities_hold(rho, states, free, epsilon, slack)
                return CrossoverResult(current, b, step, exact, int(free.size),
                                       K_free @ current[free] + bounded_term)
            # confirm once with the bounded term recomputed from scratch (class _KernelAccess)
            fresh = True
            continue
        states[entering_positive] = 1
        states[entering_negative] = -1
        fresh = False
    return CrossoverResult(current, b, max_steps, False, int(np.sum(np.abs(states) == 1)))


def _balanced(beta: NDArray[np.float64], C: float) -> bool:
    """Whether :math:`\\mathbf 1^\\top\\beta = 0` to rounding: with no free coefficient the free-set
    solve cannot restore it, and states that admit no KKT violation are then not an optimum."""
    return abs(float(beta.sum())) <= BALANCE_TOL * C * beta.size


#: Relative tolerance of the equality
#: :math:`\mathbf 1^\top\beta = 0` in the crossover's final check.
BALANCE_TOL = 1e-9


def _free_equalities_hold(residual: NDArray[np.float64], states: NDArray[np.int8],
                          free: NDArray[np.intp], epsilon: float, slack: float) -> bool:
    """Whether every free coefficient sits on its tube
    edge, :math:`y_i - f(x_i) = \\varepsilon s_i`.

    The free-set solve makes this hold unless its system was inconsistent (coinciding inputs with
    different targets both free), which the final check must not take on trust. ``free`` indexes
    the free coefficients.
    """
    # certificate.kkt_violation of a free coefficient of sign s: |r - ε s|
    return bool((np.abs(residual[free] - epsilon * states[free]) <= slack).all())


def _step_to_sign_or_box(x: NDArray[np.float64], direction: NDArray[np.float64],
                         signs: NDArray[np.int8], C: float) -> tuple[float, NDArray[np.bool_]]:
    """Largest step in [0, 1] keeping ``s·x`` in [0, C]
    for each sign s, and which coordinates block it."""
    toward = signs * direction  # rate of change of s·x
    position = signs * x
    with np.errstate(divide="ignore", invalid="ignore"):
        limits = np.where(toward < 0, position / -toward,
                          np.where(toward > 0, (C - position) / toward, np.inf))
    limits = np.maximum(limits, 0.0)
    length = float(min(1.0, np.min(limits, initial=np.inf)))
    return length, limits <= length if length < 1.0 else np.zeros(x.size, dtype=bool)


def _midpoint_bias(rho: NDArray[np.float64], states: NDArray[np.int8], epsilon: float) -> float:
    """With no free coefficient, b is the midpoint of the
    interval the KKT conditions allow (libsvm's rule)."""
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
    """Solve :math:`K_{FF}x + b\\mathbf 1 = \\text{rhs},\\ \\mathbf 1^\\top x = \\text{total}`:
    ``(x, b, unbounded)``.

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
    # LAPACK's Cholesky and its solve called directly: scipy's cho_factor / cho_solve wrappers
    # cost 5 times the work on the few free points of a small fit (96 μs against 16 μs at m = 6)
    factor, info = scipy.linalg.lapack.dpotrf(K_FF, lower=1, clean=0)
    pivots = factor.diagonal() ** 2
    if info == 0 and pivots.min() > SINGULAR_PIVOT_RATIO * pivots.max():
        right = np.empty((m, 2))
        right[:, 0], right[:, 1] = rhs, 1.0
        solution, _ = scipy.linalg.lapack.dpotrs(factor, right, lower=1, overwrite_b=1)
        mu, nu = solution[:, 0], solution[:, 1]
        b = (mu.sum() - total) / nu.sum()
        return mu - b * nu, float(b), None
    M = np.zeros((m + 1, m + 1))
    M[:m, :m] = K_FF
    M[:m, m] = M[m, :m] = 1.0
    v = np.concatenate([rhs, [total]])
    x = scipy.linalg.lstsq(M, v, cond=SINGULAR_PIVOT_RATIO, check_finite=False,
                         # QR with column pivoting: several times faster than the SVD
                         lapack_driver="gelsy")[0]
    w = v - M @ x
    consistent = np.max(np.abs(w)) <= INCONSISTENT_TOL * (1.0 + np.max(np.abs(v)))
    return x[:m], float(x[m]), None if consistent else w[:m]
