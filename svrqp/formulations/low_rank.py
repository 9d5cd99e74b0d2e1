r"""The ε-SVR dual with a factored kernel :math:`K \approx LL^\top`
(:mod:`svrqp.linalg.pivoted_cholesky`), and its error.

**Factored dual** (S0 eq. 6 with :math:`K = LL^\top`, :math:`w = L^\top\beta \in \mathbb R^r`):

.. math::

    \min_{\alpha, \alpha^*, w}\ \tfrac12 \lVert w\rVert^2
    + \varepsilon\mathbf 1^\top(\alpha + \alpha^*)
    - y^\top(\alpha^* - \alpha)
    \quad\text{s.t.}\quad w = L^\top(\alpha^* - \alpha),\quad \mathbf 1^\top(\alpha^* - \alpha) = 0,
    \quad 0 \le \alpha, \alpha^* \le C ,

as a QP in :math:`x = [\alpha; \alpha^*; w]`: :math:`P = \operatorname{diag}(0, 0, I_r)`,
:math:`q = [\varepsilon\mathbf 1 + y;\ \varepsilon\mathbf 1 - y;\ 0]`,
:math:`A = \begin{bmatrix} -L^\top & L^\top & -I_r \\ -\mathbf 1^\top & \mathbf 1^\top &
0\end{bmatrix}`, :math:`b = 0`. Its size is :math:`2n +
r` with :math:`O(nr)` nonzeros (the dense problem has :math:`n^2`). Two decision functions: the
exact kernel, :math:`f(x) = \sum_i \beta_i k(x_i, x) + b`, right when the factor is accurate; and
the model that was actually optimised, over the pivots :math:`P` only. The greedy factor reproduces
the pivot columns exactly, :math:`K_{:,P} = L L_{P,:}^\top` with :math:`L_{P,:}` lower triangular,
so the Nyström feature of any :math:`x` is :math:`\varphi(x) = L_{P,:}^{-1} k(x_P, x)` (row
:math:`i` of L for a training point) and

.. math::

    f(x) = \varphi(x)^\top w + b = \sum_{j \in P} c_j\, k(x_j, x) + b,
    \qquad c = L_{P,:}^{-\top} L^\top \beta ,

:func:`pivot_coefficients` — r kernel evaluations per prediction, and consistent with the
factored objective however large :math:`\operatorname{tr}(K - LL^\top)` is.

**Effect of the approximation.** For any feasible :math:`\beta`, the objectives with :math:`K` and
with :math:`LL^\top` differ by
:math:`\tfrac12\beta^\top E\beta \le \tfrac12 \lVert\beta\rVert^2 \operatorname{tr}E \le \tfrac12 n
C^2 \operatorname{tr}E` — the bound :func:`objective_error_bound` reports.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError
from svrqp.formulations.epsilon_svr import DUAL_STATEMENT, check_parameters
from svrqp.linalg.pivoted_cholesky import LowRankFactor
from svrqp.problems import QuadraticProgram


def dual_low_rank(L: NDArray[np.float64], y: NDArray[np.float64], C: float,
                  epsilon: float) -> QuadraticProgram:
    r"""The factored dual in :math:`x = [\alpha; \alpha^*; w]`
    (module docstring), with sparse P and A."""
    check_parameters(y, C, epsilon)
    n, r = L.shape
    if n != y.shape[0]:
        raise ProblemError(f"L has {n} rows but y has {y.shape[0]} entries")
    Lt = sp.csc_matrix(L.T)
    A = sp.vstack(
        [
            sp.hstack([-Lt, Lt, -sp.eye(r, format="csc")]), sp.hstack(
                [
                    sp.csc_matrix(-np.ones((1, n))), sp.csc_matrix(np.ones((1, n))),
                    sp.csc_matrix((1, r)),
                ]
            ),
        ], format="csc",
    )
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
    r""":math:`c = L_{P,:}^{-\top} L^\top \beta`: the factored
    model as :math:`\sum_{j \in P} c_j k(x_j, x) + b`.

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
    return scipy.linalg.solve_triangular(factor.L[factor.pivots], w, trans="T", lower=True,
                                         check_finite=False)


def objective_error_bound(factor: LowRankFactor, n: int, C: float) -> float:
    r""":math:`\tfrac12 n C^2 \operatorname{tr}(K - LL^\top)`:
    how far the factored objective can be from the exact one."""
    return 0.5 * n * C**2 * factor.trace_error
