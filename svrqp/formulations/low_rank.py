r"""The ε-SVR dual with a factored kernel :math:`K \approx LL^\top` (pivoted Cholesky), and its error.

**Factor.** Greedy pivoted Cholesky (the Nyström approximation on adaptively chosen landmarks,
Harbrecht, Peters & Schneider 2012): with residual diagonal :math:`d = \operatorname{diag}(K - LL^\top)`,
step :math:`k` picks :math:`i_k = \arg\max_i d_i` and appends the column

.. math::

    \ell_k = \bigl(K_{:, i_k} - L_{:, 1:k-1} L_{i_k, 1:k-1}^\top\bigr) / \sqrt{d_{i_k}},
    \qquad d \leftarrow d - \ell_k^2 ,

until :math:`\operatorname{tr}(K - LL^\top) = \sum_i d_i \le \tau \operatorname{tr} K` or the rank
reaches ``max_rank``. The residual :math:`E = K - LL^\top` is positive semidefinite, so
:math:`\lVert E\rVert_2 \le \operatorname{tr} E`: the trace is a reported, rigorous bound.
Memory and time are :math:`O(nr)` and :math:`O(nr^2)`; only ``r`` kernel columns are evaluated.

**Factored dual** (S0 eq. 6 with :math:`K = LL^\top`, :math:`w = L^\top\beta \in \mathbb R^r`):

.. math::

    \min_{\alpha, \alpha^*, w}\ \tfrac12 \lVert w\rVert^2 + \varepsilon\mathbf 1^\top(\alpha + \alpha^*)
    - y^\top(\alpha^* - \alpha)
    \quad\text{s.t.}\quad w = L^\top(\alpha^* - \alpha),\quad \mathbf 1^\top(\alpha^* - \alpha) = 0,
    \quad 0 \le \alpha, \alpha^* \le C ,

as a QP in :math:`x = [\alpha; \alpha^*; w]`: :math:`P = \operatorname{diag}(0, 0, I_r)`,
:math:`q = [\varepsilon\mathbf 1 + y;\ \varepsilon\mathbf 1 - y;\ 0]`,
:math:`A = \begin{bmatrix} -L^\top & L^\top & -I_r \\ -\mathbf 1^\top & \mathbf 1^\top & 0\end{bmatrix}`,
:math:`b = 0`. Its size is :math:`2n + r` with :math:`O(nr)` nonzeros (the dense problem has
:math:`n^2`). Two decision functions: the exact kernel,
:math:`f(x) = \sum_i \beta_i k(x_i, x) + b`, right when the factor is accurate; and the model
that was actually optimised, over the pivots :math:`P` only. The greedy factor reproduces the pivot
columns exactly, :math:`K_{:,P} = L L_{P,:}^\top` with :math:`L_{P,:}` lower triangular, so the
Nyström feature of any :math:`x` is :math:`\varphi(x) = L_{P,:}^{-1} k(x_P, x)` (row :math:`i` of L
for a training point) and

.. math::

    f(x) = \varphi(x)^\top w + b = \sum_{j \in P} c_j\, k(x_j, x) + b,
    \qquad c = L_{P,:}^{-\top} L^\top \beta ,

:func:`pivot_coefficients` — r kernel evaluations per prediction, and consistent with the
factored objective however large :math:`\operatorname{tr}(K - LL^\top)` is.

**Effect of the approximation.** For any feasible :math:`\beta`, the objectives with :math:`K` and
with :math:`LL^\top` differ by :math:`\tfrac12\beta^\top E\beta \le \tfrac12 \lVert\beta\rVert^2 \operatorname{tr}E
\le \tfrac12 n C^2 \operatorname{tr}E` — the bound :func:`objective_error_bound` reports.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError
from svrqp.formulations.epsilon_svr import DUAL_STATEMENT, check_parameters
from svrqp.kernel_columns import KernelColumns
from svrqp.problems import QuadraticProgram


@dataclass
class LowRankFactor:
    """:math:`K \\approx LL^\\top` with the pivots chosen and the trace of the residual."""

    L: NDArray[np.float64]
    pivots: NDArray[np.intp]
    trace_error: float
    trace: float

    @property
    def rank(self) -> int:
        """Number of columns of L."""
        return self.L.shape[1]

    @property
    def relative_trace_error(self) -> float:
        """:math:`\\operatorname{tr}(K - LL^\\top) / \\operatorname{tr} K`."""
        return self.trace_error / self.trace if self.trace > 0 else 0.0


#: With ``give_up``, the decay of the residual trace is checked at ranks 32, 64, 128, …
GIVE_UP_FIRST_CHECK = 32

#: … and the factorisation stops when a geometric decay at the rate seen since half that rank
#: would need more than this multiple of ``max_rank`` to reach ``tol``. Kernel spectra decay
#: faster than geometrically when they decay at all, so the projection errs on the side of going on.
GIVE_UP_MARGIN = 2.0


def pivoted_cholesky(columns: KernelColumns, *, max_rank: int, tol: float = 1e-8,
                     give_up: bool = False, cache: bool = True) -> LowRankFactor:
    """Greedy pivoted Cholesky of the Gram matrix behind ``columns`` (module docstring).

    Parameters
    ----------
    columns
        Kernel columns of the training inputs.
    max_rank
        Largest number of columns of L.
    tol
        Stop when :math:`\\operatorname{tr}(K - LL^\\top) \\le` ``tol`` · :math:`\\operatorname{tr} K`.
    give_up
        Also stop as soon as the decay of the residual trace shows that ``tol`` is out of reach
        within ``max_rank`` (see :data:`GIVE_UP_MARGIN`): for a caller that only wants a factor
        if it is good, such as :func:`svrqp.dual_ipm.solve_exact_from_data`. The factor returned
        then misses ``tol`` (its ``relative_trace_error`` says by how much).
    cache
        Keep the pivot columns in ``columns``' cache, for a caller that reads them again (the
        crossover of :func:`svrqp.dual_ipm.solve_exact_from_data`); without, each column is
        computed and dropped (writing an n×rank cache costs 10–25 % of the factorisation's
        time at n = 30000, measured).
    """
    n = columns.n
    if max_rank < 1:
        raise ProblemError(f"max_rank must be at least 1, got {max_rank}")
    if not tol >= 0:
        raise ProblemError(f"tol must be non-negative, got {tol}")
    max_rank = min(max_rank, n)
    residual = columns.diagonal().astype(float)
    trace = float(residual.sum())
    L = np.zeros((n, max_rank), order="F")
    pivots = []
    remaining_at: dict[int, float] = {}  # residual trace at ranks 16, 32, 64, …
    for k in range(max_rank):
        remaining = float(residual.sum())
        if remaining <= tol * trace:
            break
        if k >= GIVE_UP_FIRST_CHECK // 2 and k & (k - 1) == 0:  # a power of two
            remaining_at[k] = remaining
            if give_up and k >= GIVE_UP_FIRST_CHECK and _out_of_reach(remaining_at[k // 2], remaining, k,
                                                                     tol * trace, max_rank):
                break
        pivot = int(np.argmax(residual))
        if residual[pivot] <= 0.0:
            break  # the remaining residual is rounding noise
        column = (columns if cache else columns.uncached)(np.array([pivot]))[:, 0] - L[:, :k] @ L[pivot, :k]
        L[:, k] = column / np.sqrt(residual[pivot])
        residual -= L[:, k] ** 2
        residual[pivot] = 0.0
        np.maximum(residual, 0.0, out=residual)  # rounding can leave tiny negatives
        pivots.append(pivot)
    rank = len(pivots)
    return LowRankFactor(np.ascontiguousarray(L[:, :rank]), np.array(pivots, dtype=np.intp),
                         float(residual.sum()), trace)


def _out_of_reach(earlier: float, now: float, k: int, target: float, max_rank: int) -> bool:
    """Whether the trace, falling from ``earlier`` (rank k/2) to ``now`` (rank k) at a geometric
    rate, would need more than ``GIVE_UP_MARGIN * max_rank`` columns to reach ``target``."""
    if now >= earlier:
        return True
    rate_per_column = np.log(now / earlier) / (k / 2)  # negative
    needed = k + np.log(target / now) / rate_per_column
    return bool(needed > GIVE_UP_MARGIN * max_rank)


def dual_low_rank(L: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float) -> QuadraticProgram:
    r"""The factored dual in :math:`x = [\alpha; \alpha^*; w]` (module docstring), with sparse P and A."""
    check_parameters(y, C, epsilon)
    n, r = L.shape
    if n != y.shape[0]:
        raise ProblemError(f"L has {n} rows but y has {y.shape[0]} entries")
    Lt = sp.csc_matrix(L.T)
    A = sp.vstack([
        sp.hstack([-Lt, Lt, -sp.eye(r, format="csc")]),
        sp.hstack([sp.csc_matrix(-np.ones((1, n))), sp.csc_matrix(np.ones((1, n))), sp.csc_matrix((1, r))]),
    ], format="csc")
    return QuadraticProgram(
        P=sp.diags(np.concatenate([np.zeros(2 * n), np.ones(r)]), format="csc"),
        q=np.concatenate([epsilon + y, epsilon - y, np.zeros(r)]),
        A=A,
        b=np.zeros(r + 1),
        lb=np.concatenate([np.zeros(2 * n), np.full(r, -np.inf)]),
        ub=np.concatenate([np.full(2 * n, float(C)), np.full(r, np.inf)]),
        name=f"epsilon-SVR dual, factored kernel K = L L^T (rank {r}), x = [alpha; alpha*; w]",
        statement=DUAL_STATEMENT + r",\qquad K \approx LL^\top,\; w = L^\top(\alpha^*-\alpha)",
        check_psd=False,  # a 0/1 diagonal
    )


def beta_from_solution(n: int, x: NDArray[np.float64]) -> NDArray[np.float64]:
    r""":math:`\beta = \alpha^* - \alpha` from a solution :math:`x = [\alpha; \alpha^*; w]`."""
    return x[n:2 * n] - x[:n]


def pivot_coefficients(factor: LowRankFactor, beta: NDArray[np.float64]) -> NDArray[np.float64]:
    r""":math:`c = L_{P,:}^{-\top} L^\top \beta`: the factored model as :math:`\sum_{j \in P} c_j k(x_j, x) + b`.

    Parameters
    ----------
    factor
        The pivoted Cholesky factor the dual was solved with.
    beta
        Its solution :math:`\alpha^* - \alpha`, shape ``(n,)``.

    Returns
    -------
    ndarray of shape ``(rank,)``
        Coefficients of the pivots ``factor.pivots``, in that order.
    """
    if beta.shape != (factor.L.shape[0],):
        raise ProblemError(f"beta must have {factor.L.shape[0]} entries, got shape {beta.shape}")
    w = factor.L.T @ beta
    return scipy.linalg.solve_triangular(factor.L[factor.pivots], w, trans="T", lower=True, check_finite=False)


def objective_error_bound(factor: LowRankFactor, n: int, C: float) -> float:
    r""":math:`\tfrac12 n C^2 \operatorname{tr}(K - LL^\top)`: how far the factored objective can be from the exact one."""
    return 0.5 * n * C**2 * factor.trace_error
