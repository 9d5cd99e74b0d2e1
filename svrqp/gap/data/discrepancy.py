r"""Out-of-sample fits of linear discrepancy models, many candidates at once.

A discrepancy model explains the baseline's residual :math:`r` on the real rows by base
regressors :math:`B` (an intercept and the model's features, or the prediction) plus the
columns of one candidate block — one column :math:`z`, or a *partner* column :math:`x` shared
by several blocks and one column :math:`z` of its own (``lag``: :math:`[x, \ell_\tau]`):

.. math::

    r = B\beta + Z\gamma + e,\qquad Z = [z] \ \text{or}\ [x, z].

It is scored by blocked cross-validation (:func:`svrqp.gap.data.runs.blocked_folds`). For a
fold with training rows :math:`T` and test rows :math:`V`, the Frisch–Waugh–Lovell theorem
gives the least-squares fit on :math:`T` in two small steps — partial the base out,

.. math::

    A = B_T^\top B_T + \lambda I,\quad \beta_0 = A^{-1}B_T^\top r_T,\quad
    W = A^{-1} B_T^\top Z_T,\quad \tilde r = r - B\beta_0,\quad \tilde Z = Z - B W,

then regress on what is left and score the test rows:

.. math::

    \gamma = (\tilde Z_T^\top \tilde Z_T + \lambda I)^{-1}\tilde Z_T^\top \tilde r_T,\qquad
    \mathrm{SSE}_V = \tilde r_V^\top\tilde r_V - 2\gamma^\top \tilde Z_V^\top\tilde r_V
        + \gamma^\top \tilde Z_V^\top\tilde Z_V\,\gamma .

:math:`\tilde Z` is never formed: with :math:`C_S = B_S^\top Z_S`, :math:`M_S = B_S^\top B_S`
and :math:`S` the test rows of a fold (training sums = totals − test sums), for any two
columns :math:`a, b`

.. math::

    \tilde a_S^\top \tilde b_S = a_S^\top b_S - C_{a,S}^\top W_b - W_a^\top C_{b,S} + W_a^\top M_S
    W_b, \qquad
    \tilde a_S^\top \tilde r_S = a_S^\top r_S -
    C_{a,S}^\top\beta_0 - W_a^\top(B_S^\top r_S - M_S\beta_0),

so thousands of candidate columns (transforms × time constants × surrogates) cost one
matrix product :math:`[B, r]^\top Z` and one column-wise reduction per pass, plus
:math:`2\times2` solves in closed form. The ridge :math:`\lambda` is :data:`RIDGE` times the
number of training rows: it keeps both solves defined when a column is collinear with the
base; with standardised columns it changes no well-posed fit noticeably.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from svrqp.gap.data.runs import blocked_folds

RIDGE = 1e-8
"""Ridge per training row added to :math:`A` and to :math:`\\tilde Z_T^\\top \\tilde Z_T`."""


@dataclass(frozen=True)
class _Fold:
    test: slice  # rows of this fold in fold-sorted order
    n_train: int
    A_inv: np.ndarray  # inverse of the small (p x p) matrix A, applied to many right-hand sides
    beta0: np.ndarray
    M_train: np.ndarray
    M_test: np.ndarray
    q_train: np.ndarray  # B_T' r_T - M_T beta0
    q_test: np.ndarray  # B_V' r_V - M_V beta0
    rr_test: float  # |r~_V|^2


@dataclass(frozen=True)
class _Sums:
    """Per-set sums of one column family: ``C = B'Z``, ``s = r'Z``, ``S = diag(Z'Z)``."""

    C: np.ndarray
    s: np.ndarray
    S: np.ndarray

    def __sub__(self, other: _Sums) -> _Sums:
        return _Sums(self.C - other.C, self.s - other.s, self.S - other.S)


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
        Out-of-sample errors of the base model alone (caller's row order).
    sse_base : float
        Their sum of squares.
    """

    def __init__(self, r: np.ndarray, B: np.ndarray, folds: list[np.ndarray]):
        self.n = len(r)
        self.p = B.shape[1]
        # Rows are kept sorted by fold so each fold's test rows are one slice (no copies).
        self._perm = np.concatenate(folds)
        self._Br = np.column_stack([B, r])[self._perm]
        B_sorted, r_sorted = self._Br[:, :-1], self._Br[:, -1]
        M_total = B_sorted.T @ B_sorted
        b_total = B_sorted.T @ r_sorted
        self._folds: list[_Fold] = []
        self.errors_base = np.empty(self.n)
        start = 0
        for test_rows in folds:
            test = slice(start, start + len(test_rows))
            start = test.stop
            B_test, r_test = B_sorted[test], r_sorted[test]
            M_test, b_test = B_test.T @ B_test, B_test.T @ r_test
            M_train, b_train = M_total - M_test, b_total - b_test
            n_train = self.n - len(test_rows)
            A_inv = cho_solve(cho_factor(M_train + RIDGE * n_train * np.eye(self.p)),
                              np.eye(self.p))
            beta0 = A_inv @ b_train
            e_test = r_test - B_test @ beta0
            self.errors_base[test_rows] = e_test
            self._folds.append(_Fold(test, n_train, A_inv, beta0, M_train, M_test,
                                     b_train - M_train @ beta0, b_test - M_test @ beta0,
                                     float(e_test @ e_test)))
        self.sse_base = float(self.errors_base @ self.errors_base)
        self._Br_test_T = [np.ascontiguousarray(self._Br[f.test].T) for f in self._folds]

    def _sums(self, Z: np.ndarray, k: int) -> _Sums:
        rows = self._folds[k].test
        Z_rows = Z[rows]
        Cs = (self._Br_test_T[k] @ Z_rows.reshape(len(Z_rows), -1)).reshape(-1, *Z.shape[1:])
        return _Sums(Cs[:-1], Cs[-1], np.einsum("n...,n...->...", Z_rows, Z_rows))

    def sse(self, Z: np.ndarray, partner: np.ndarray | None = None) -> np.ndarray:
        """Out-of-sample sum of squared errors with each candidate block added.

        Parameters
        ----------
        Z : ndarray, shape (n, q, v)
            Own column of every block; rows in the caller's order (standardised columns
            advised).
        partner : ndarray, shape (n, q), optional
            Column shared by the ``v`` blocks ``Z[:, j, :]``: block ``(j, t)`` is
            ``[partner[:, j], Z[:, j, t]]``. Without it every block is ``[Z[:, j, t]]``.

        Returns
        -------
        ndarray, shape (q, v)
        """
        _, q, v = Z.shape
        Zs = np.ascontiguousarray(Z[self._perm])
        Xs = None if partner is None else np.ascontiguousarray(partner[self._perm])
        test_z = [self._sums(Zs, k) for k in range(len(self._folds))]
        total_z = _total(test_z)
        if Xs is not None:
            test_x = [self._sums(Xs, k) for k in range(len(self._folds))]
            total_x = _total(test_x)
            test_xz = [np.einsum("nq,nqv->qv", Xs[f.test], Zs[f.test]) for f in self._folds]
            total_xz = sum(test_xz)
        sse = np.zeros((q, v))
        for k, fold in enumerate(self._folds):
            train_z = total_z - test_z[k]
            W_z = np.tensordot(fold.A_inv, train_z.C, axes=1)
            G22, g2 = _partialled(train_z, W_z, fold, train=True)
            H22, h2 = _partialled(test_z[k], W_z, fold, train=False)
            ridge = RIDGE * fold.n_train
            if Xs is None:
                gamma2 = g2 / (np.maximum(G22, 0.0) + ridge)
                sse += fold.rr_test - 2 * gamma2 * h2 + gamma2**2 * H22
                continue
            train_x = total_x - test_x[k]
            W_x = fold.A_inv @ train_x.C
            G11, g1 = (a[:, None] for a in _partialled(train_x, W_x, fold, train=True))
            H11, h1 = (a[:, None] for a in _partialled(test_x[k], W_x, fold, train=False))
            G12 = _cross(total_xz - test_xz[k], train_x.C, train_z.C, W_x, W_z, fold.M_train)
            H12 = _cross(test_xz[k], test_x[k].C, test_z[k].C, W_x, W_z, fold.M_test)
            # Closed-form 2x2 ridge solve for (gamma1, gamma2) of every block.
            G11, G22 = G11 + ridge, G22 + ridge
            det = G11 * G22 - G12**2
            gamma1 = (G22 * g1 - G12 * g2) / det
            gamma2 = (G11 * g2 - G12 * g1) / det
            sse += (fold.rr_test - 2 * (gamma1 * h1 + gamma2 * h2)
                    + gamma1**2 * H11 + 2 * gamma1 * gamma2 * H12 + gamma2**2 * H22)
        return sse

    def gain(self, Z: np.ndarray, partner: np.ndarray | None = None) -> np.ndarray:
        """Relative out-of-sample gain
        :math:`1 - \\mathrm{SSE}(B+Z)/\\mathrm{SSE}(B)`, shape (q, v)."""
        return 1.0 - self.sse(Z, partner) / self.sse_base


def _total(parts: list[_Sums]) -> _Sums:
    return _Sums(sum(p.C for p in parts), sum(p.s for p in parts), sum(p.S for p in parts))


def _partialled(sums: _Sums, W: np.ndarray, fold: _Fold,
                train: bool) -> tuple[np.ndarray, np.ndarray]:
    """:math:`\\tilde z^\\top\\tilde z` and
    :math:`\\tilde z^\\top\\tilde r` of every column on one set."""
    M, qvec = (fold.M_train, fold.q_train) if train else (fold.M_test, fold.q_test)
    p = W.shape[0]
    C2, W2 = sums.C.reshape(p, -1), W.reshape(p, -1)
    shape = sums.S.shape
    zz = sums.S - (2 * np.einsum("pm,pm->m", C2,
                                 W2) - np.einsum("pm,pm->m", W2, M @ W2)).reshape(shape)
    zr = sums.s - (fold.beta0 @ C2 + qvec @ W2).reshape(shape)
    return zz, zr


def _cross(S_xz, C_x, C_z, W_x, W_z, M) -> np.ndarray:
    """:math:`\\tilde x^\\top\\tilde z` for partner ``x`` (q,) against own columns ``z`` (q, v)."""
    return (S_xz - np.einsum("pq,pqv->qv", C_x, W_z) - np.einsum("pq,pqv->qv", W_x, C_z)
            + np.einsum("pq,pqv->qv", M @ W_x, W_z))


def _fit_and_predict(r_fit: np.ndarray, D_fit: np.ndarray, D_new: np.ndarray) -> np.ndarray:
    coef = np.linalg.lstsq(D_fit, r_fit, rcond=None)[0]
    return D_new @ coef


def nested_errors(
    r: np.ndarray,
    B: np.ndarray,
    own: np.ndarray,
    partner: np.ndarray | None,
    folds: list[np.ndarray],
    groups: np.ndarray,
) -> np.ndarray:
    """Out-of-sample errors of ``r ~ B + [partner, own[:, variant]]``, variant chosen per fold.

    Parameters
    ----------
    r : ndarray, shape (n,)
        Residual on the real rows.
    B : ndarray, shape (n, p)
        Base regressors (with an intercept).
    own : ndarray, shape (n, v)
        The effect's own column for each of ``v`` variants; with ``v > 1`` the best is
        chosen by inner blocked CV on each outer fold's training rows.
    partner : ndarray, shape (n,) or None
        Column every variant also holds.
    folds : list of ndarray
        Outer blocked folds.
    groups : ndarray of int
        Group code per row (for the inner folds).

    Returns
    -------
    ndarray, shape (n,)
    """
    n, v = own.shape
    errors = np.empty(n)
    for test in folds:
        train = np.setdiff1d(np.arange(n), test, assume_unique=True)
        variant = 0
        if v > 1:
            inner = CrossValidatedDiscrepancy(r[train], B[train], blocked_folds(groups[train]))
            shared = None if partner is None else partner[train, None]
            variant = int(np.argmax(inner.gain(own[train, None, :], shared)[0]))
        columns = [B, own[:, variant]] + ([] if partner is None else [partner])
        D = np.column_stack(columns)
        errors[test] = r[test] - _fit_and_predict(r[train], D[train], D[test])
    return errors
