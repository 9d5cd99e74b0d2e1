r"""Out-of-sample fits of linear discrepancy models, many candidates at once.

A discrepancy model explains the baseline's residual :math:`r` on the real rows by base
regressors :math:`B` (an intercept and the model's features, or the prediction) plus the
:math:`k \le 2` columns :math:`Z` of one candidate transform:

.. math::

    r = B\beta + Z\gamma + e .

It is scored by blocked cross-validation (:func:`svrqp.gap.blocks.blocked_folds`). For a
fold with training rows :math:`T` and test rows :math:`V`, the Frisch–Waugh–Lovell theorem
gives the least-squares fit on :math:`T` in two small steps — partial the base out,

.. math::

    A = B_T^\top B_T + \lambda I,\quad \beta_0 = A^{-1}B_T^\top r_T,\quad
    W = A^{-1} B_T^\top Z_T,\quad \tilde r = r - B\beta_0,\quad \tilde Z = Z - B W,

then regress on what is left:

.. math::

    \gamma = (\tilde Z_T^\top \tilde Z_T + \lambda I)^{-1}\tilde Z_T^\top \tilde r_T,\qquad
    e_V = \tilde r_V - \tilde Z_V\gamma,\qquad
    \mathrm{SSE}_V = \tilde r_V^\top\tilde r_V - 2\gamma^\top \tilde Z_V^\top\tilde r_V
        + \gamma^\top \tilde Z_V^\top\tilde Z_V\,\gamma .

:meth:`CrossValidatedDiscrepancy.sse` never forms :math:`\tilde Z`: with
:math:`C_S = B_S^\top Z_S` and :math:`M_S = B_S^\top B_S` (:math:`S` = test rows of a fold,
training sums = totals − test sums),

.. math::

    \tilde Z_S^\top \tilde Z_S = Z_S^\top Z_S - C_S^\top W - W^\top C_S + W^\top M_S W,\qquad
    \tilde Z_S^\top \tilde r_S = Z_S^\top r_S - C_S^\top\beta_0 - W^\top(B_S^\top r_S - M_S\beta_0),

so thousands of candidate columns (transforms × time constants × surrogates) cost one pass
over the data plus :math:`k\times k` solves. :meth:`CrossValidatedDiscrepancy.errors` forms
the per-row out-of-sample errors directly, for the few models that are reported. The ridge
:math:`\lambda` is :data:`RIDGE` times the number of training rows: it keeps both solves
defined when a column is collinear with the base, and with standardised columns it changes
no well-posed fit noticeably.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

RIDGE = 1e-8
"""Ridge per training row added to :math:`A` and to :math:`\\tilde Z_T^\\top \\tilde Z_T`."""


@dataclass(frozen=True)
class _Fold:
    test: slice  # rows of this fold in fold-sorted order
    n_train: int
    factor: tuple  # Cholesky factor of A
    beta0: np.ndarray
    M_train: np.ndarray
    M_test: np.ndarray
    q_train: np.ndarray  # B_T' r_T - M_T beta0
    q_test: np.ndarray  # B_V' r_V - M_V beta0
    rr_test: float  # |r~_V|^2


class CrossValidatedDiscrepancy:
    """Blocked-CV scorer of ``r ~ B + Z`` for a fixed residual, base and folds.

    Parameters
    ----------
    r : ndarray, shape (n,)
        Residual of the baseline on the real rows.
    B : ndarray, shape (n, p)
        Base regressors (include a column of ones for an intercept).
    folds : list of ndarray of int
        Test rows of each fold (disjoint, covering all rows); training rows are the others.

    Attributes
    ----------
    errors_base : ndarray, shape (n,)
        Out-of-sample errors of the base model alone.
    sse_base : float
        Their sum of squares.
    """

    def __init__(self, r: np.ndarray, B: np.ndarray, folds: list[np.ndarray]):
        self.n = len(r)
        # Rows are kept sorted by fold so each fold's test rows are one slice (no copies).
        self._perm = np.concatenate(folds)
        self._r = r[self._perm]
        self._B = B[self._perm]
        M_total = self._B.T @ self._B
        b_total = self._B.T @ self._r
        self._folds: list[_Fold] = []
        start = 0
        p = B.shape[1]
        for test_rows in folds:
            test = slice(start, start + len(test_rows))
            start = test.stop
            B_test, r_test = self._B[test], self._r[test]
            M_test, b_test = B_test.T @ B_test, B_test.T @ r_test
            M_train, b_train = M_total - M_test, b_total - b_test
            n_train = self.n - len(test_rows)
            factor = cho_factor(M_train + RIDGE * n_train * np.eye(p))
            beta0 = cho_solve(factor, b_train)
            e_test = r_test - B_test @ beta0
            self._folds.append(
                _Fold(test, n_train, factor, beta0, M_train, M_test,
                      b_train - M_train @ beta0, b_test - M_test @ beta0, float(e_test @ e_test))
            )
        self.errors_base = self.errors(np.zeros((self.n, 1, 1)))[:, 0]
        self.sse_base = float(self.errors_base @ self.errors_base)

    def sse(self, Z: np.ndarray) -> np.ndarray:
        """Out-of-sample sum of squared errors with each candidate block added.

        Parameters
        ----------
        Z : ndarray, shape (n, m, k)
            ``m`` candidate blocks of ``k`` columns each, rows in the caller's order
            (standardised columns advised).

        Returns
        -------
        ndarray, shape (m,)
        """
        n, m, k = Z.shape
        # One contiguous (n, m) array per block column, rows sorted by fold: every product
        # below is then a BLAS call or a single streaming reduction over a slice.
        Z_sorted = Z[self._perm]
        columns = [np.ascontiguousarray(Z_sorted[:, :, i]) for i in range(k)]
        parts = []
        for fold in self._folds:
            B_test, r_test = self._B[fold.test], self._r[fold.test]
            Z_test = [c[fold.test] for c in columns]
            C = np.stack([B_test.T @ z for z in Z_test], axis=2)
            S = np.empty((m, k, k))
            for i in range(k):
                for j in range(i + 1):
                    S[:, i, j] = S[:, j, i] = np.einsum("nm,nm->m", Z_test[i], Z_test[j])
            s = np.stack([r_test @ z for z in Z_test], axis=1)
            parts.append((C, S, s))
        C_total = sum(part[0] for part in parts)
        S_total = sum(part[1] for part in parts)
        s_total = sum(part[2] for part in parts)
        sse = np.zeros(m)
        for fold, (C_test, S_test, s_test) in zip(self._folds, parts):
            C_train = C_total - C_test
            W = cho_solve(fold.factor, C_train.reshape(C_train.shape[0], -1)).reshape(C_train.shape)
            G_train = _partialled_gram(S_total - S_test, C_train, W, fold.M_train)
            g_train = (s_total - s_test - np.einsum("p,pmi->mi", fold.beta0, C_train)
                       - np.einsum("p,pmi->mi", fold.q_train, W))
            gamma = _solve_small(G_train, g_train, RIDGE * fold.n_train)
            G_test = _partialled_gram(S_test, C_test, W, fold.M_test)
            g_test = s_test - np.einsum("p,pmi->mi", fold.beta0, C_test) - np.einsum("p,pmi->mi", fold.q_test, W)
            sse += (fold.rr_test - 2 * np.einsum("mi,mi->m", gamma, g_test)
                    + np.einsum("mi,mij,mj->m", gamma, G_test, gamma))
        return sse

    def gain(self, Z: np.ndarray) -> np.ndarray:
        """Relative out-of-sample gain :math:`1 - \\mathrm{SSE}(B+Z)/\\mathrm{SSE}(B)` (shape (m,))."""
        return 1.0 - self.sse(Z) / self.sse_base

    def errors(self, Z: np.ndarray) -> np.ndarray:
        """Per-row out-of-sample errors with each candidate block added.

        Parameters
        ----------
        Z : ndarray, shape (n, m, k)
            As for :meth:`sse`; meant for a few blocks (it forms :math:`\\tilde Z`).

        Returns
        -------
        ndarray, shape (n, m)
            Errors in the caller's row order.
        """
        n, m, k = Z.shape
        Zs = Z[self._perm].reshape(n, m * k)
        C_total = self._B.T @ Zs
        out = np.empty((n, m))
        for fold in self._folds:
            B_test = self._B[fold.test]
            W = cho_solve(fold.factor, C_total - B_test.T @ Zs[fold.test])
            Zt = Zs - self._B @ W
            rt = self._r - self._B @ fold.beta0
            train = np.ones(n, dtype=bool)
            train[fold.test] = False
            Zt_train = Zt[train].reshape(-1, m, k)
            G = np.einsum("nmi,nmj->mij", Zt_train, Zt_train)
            gamma = _solve_small(G, np.einsum("nmi,n->mi", Zt_train, rt[train]), RIDGE * fold.n_train)
            out[fold.test] = rt[fold.test, None] - np.einsum("nmi,mi->nm", Zt[fold.test].reshape(-1, m, k), gamma)
        unsorted = np.empty_like(out)
        unsorted[self._perm] = out
        return unsorted


def _partialled_gram(S_zz: np.ndarray, C: np.ndarray, W: np.ndarray, M: np.ndarray) -> np.ndarray:
    """:math:`Z^\\top Z - C^\\top W - W^\\top C + W^\\top M W` per candidate block, shape (m, k, k)."""
    CW = np.einsum("pmi,pmj->mij", C, W)
    return S_zz - CW - CW.transpose(0, 2, 1) + np.einsum("pmi,pq,qmj->mij", W, M, W, optimize=True)


def _solve_small(G: np.ndarray, g: np.ndarray, ridge: float) -> np.ndarray:
    """Batch of ridge-stabilised :math:`k\\times k` systems ``(G + ridge I) gamma = g``."""
    k = G.shape[1]
    if k == 1:
        return g / (np.maximum(G[:, :, 0], 0.0) + ridge)
    return np.linalg.solve(G + ridge * np.eye(k), g[:, :, None])[:, :, 0]
