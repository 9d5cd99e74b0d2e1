"""Kernel columns on demand, each computed once: :math:`K_{:, j} = k(X, x_j)` without forming K.

Solvers that touch only some columns of the Gram matrix — the support vectors in an active-set
crossover, the pivots of a pivoted Cholesky factorisation — use this cache, so the memory is
O(n · columns used) instead of O(n²). A block of columns is one matrix product of the left and
right factors of :func:`svrqp.kernels.left_factor` and :func:`svrqp.kernels.right_factor` (both
formed once for X, the right one's rows picked per block) and an in-place finish, the same code as
:func:`svrqp.kernels.gram`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError
from svrqp.kernels import (
    centred,
    check_kernel_parameters,
    factors,
    finish_in_place,
    gram_diagonal,
    require_finite_kernel,
)

#: Kernel entries formed at once by :meth:`KernelColumns.products` (a row block, or a square tile):
#: a 1 MB block stays in cache and its memory is reused (a large block is a fresh allocation whose
#: page faults cost more than the kernel itself: 2.5× slower at 4000 × 3550 entries; of 2^16 to
#: 2^19 entries, 2^17 was fastest at 4000 × 1000 and 4000 × 3550, measured).
PRODUCT_BLOCK_ENTRIES = 2**17
#: :meth:`KernelColumns.products` forms the tiles of :math:`K_{idx, idx}` once for both halves only
#: when ``idx`` holds at least this share of the points. They save :math:`|idx|/2n` of the entries,
#: and splitting the rows copies the left factor: on the thermal panel generator the plain row
#: blocks took 0.70× the split's time for 1 column in 64 at n = 2000, 0.92–1.00× up to 1 in 8, and
#: 1.05–1.18× from 1 in 6 on (n = 2000 and 8000, measured); the crossover's updates of a few
#: columns are the common case.
SYMMETRIC_MIN_SHARE = 0.25


class KernelColumns:
    """Columns of the Gram matrix of ``X`` (kernel parameters as in :func:`svrqp.kernels.gram`).

    Calling the object with an index array returns the columns as an ``(n, len(idx))`` array;
    columns already computed are taken from the cache.
    """

    def __init__(self, X: NDArray[np.float64], *, kernel: str = "rbf", gamma: float = 1.0,
                 degree: int = 3, coef0: float = 0.0) -> None:
        self.X = np.asarray(X, dtype=float)
        if self.X.ndim != 2:
            raise ProblemError(f"X must be 2-D, got shape {self.X.shape}")
        check_kernel_parameters(kernel, gamma, degree)
        self.parameters = {"kernel": kernel, "gamma": gamma, "degree": degree, "coef0": coef0}
        self._points = centred(kernel, self.X)[0]  # as in gram(): RBF values from centred inputs
        with np.errstate(over="ignore", invalid="ignore"):  # finish_in_place checks for overflow
            # shared by every column block; a block takes the right factor's rows of its columns
            self._left, self._right = factors(self._points, kernel, gamma, coef0)
        # The cache: column j of K is _store[:, _slot[j]] (-1: not computed). One Fortran array
        # (capacity doubled as it fills) so that serving many cached columns is one gather, not a
        # stack of small arrays; the slots are an array so that looking them up is one gather too.
        self._slot = np.full(self.X.shape[0], -1, dtype=np.intp)
        self._used = 0
        self._store = np.empty((self.X.shape[0], 0), order="F")
        self.evaluated = 0  # number of columns computed (not served from the cache)

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.X.shape[0]

    def diagonal(self) -> NDArray[np.float64]:
        """:math:`K_{ii}` for every sample, in closed form (:func:`svrqp.kernels.gram_diagonal`)."""
        return gram_diagonal(self.X, **self.parameters)

    def __call__(self, idx: NDArray[np.intp]) -> NDArray[np.float64]:
        """:math:`K_{:, idx}`, shape ``(n, len(idx))``;
        columns not yet cached are computed in one block."""
        slots = self._slots(idx)  # first: computing a missing column may grow the store
        return self._store[:, slots]

    def block(self, rows: NDArray[np.intp], idx: NDArray[np.intp]) -> NDArray[np.float64]:
        """:math:`K_{rows, idx}`, shape ``(len(rows), len(idx))``, from the cached columns
        (computed and cached first where missing): a caller that needs only these rows, such as
        the crossover's :math:`K_{FF}`, gathers them without the whole columns."""
        slots = self._slots(idx)  # first: computing a missing column may grow the store
        # one gather, as DenseColumns.block: np.ix_'s checks cost more than a small block
        return self._store[np.asarray(rows, dtype=np.intp).ravel()[:, None], slots]

    def _slots(self, idx: NDArray[np.intp]) -> NDArray[np.intp]:
        """The cache slots of the columns ``idx``; columns
        not yet cached are computed in one block."""
        idx = np.asarray(idx, dtype=np.intp).ravel()
        slots = self._slot[idx]
        if (slots < 0).any():
            missing = np.unique(idx[slots < 0])
            used = self._used
            if used + missing.size > self._store.shape[1]:
                grown = np.empty((self.n, max(2 * self._store.shape[1], used + missing.size)),
                                 order="F")
                grown[:, :used] = self._store[:, :used]
                self._store = grown
            # formed in place: a fresh n × |missing| block and its copy cost as much as the kernel
            self._columns_into(missing, self._store[:, used:used + missing.size])
            self._slot[missing] = np.arange(used, used + missing.size)
            self._used += missing.size
            self.evaluated += missing.size
            slots = self._slot[idx]
        return slots

    def uncached(self, idx: NDArray[np.intp]) -> NDArray[np.float64]:
        """:math:`K_{:, idx}` computed afresh and not stored
        (for a caller that reads each column once)."""
        idx = np.asarray(idx, dtype=np.intp).ravel()
        block = np.empty((self.n, idx.size))
        self._columns_into(idx, block)
        return block

    def _columns_into(self, idx: NDArray[np.intp], out: NDArray[np.float64]) -> None:
        """Write the columns ``idx`` of K into ``out``, shape ``(n, len(idx))``, in either order."""
        with np.errstate(over="ignore", invalid="ignore"):  # finish_in_place checks for overflow
            np.matmul(self._left, self._right[idx].T, out=out)
        finish_in_place(out, self.parameters["kernel"], self.parameters["degree"])

    def products(self, idx: NDArray[np.intp], v: NDArray[np.float64]) -> NDArray[np.float64]:
        r""":math:`K_{:, idx}\, v` in blocks, the columns neither cached nor kept.

        The crossover's bounded term needs the columns of every coefficient at :math:`\pm C` only
        in this product: recomputing them is cheaper than caching thousands of columns that are
        never read again. The factors come from the ones formed for X at construction (no
        re-centring or norms per block) and one block buffer is reused. The rows of ``idx``
        themselves use the symmetry of K: each tile of :math:`K_{idx, idx}` above the diagonal
        is formed once and serves both :math:`K_{PQ}v_Q` and :math:`K_{QP}v_P = K_{PQ}^\top v_P`
        (the blocked symmetric matrix–vector product of BLAS ``dsymv``; Golub & Van Loan 2013,
        *Matrix Computations*, §1.3), so about :math:`n\,|idx| - |idx|^2/2` kernel entries are
        formed instead of :math:`n\,|idx|` — nearly half when most points are at a bound.
        Below ``SYMMETRIC_MIN_SHARE`` of the points, plain row blocks over all points are cheaper.
        Overflow is checked once on the result instead of on every block: a non-finite kernel
        entry makes its row of the product non-finite (inf·0 and NaN·v are NaN).
        """
        idx, inverse = np.unique(np.asarray(idx, dtype=np.intp).ravel(), return_inverse=True)
        if idx.size == 0:
            return np.zeros(self.n)
        v = np.bincount(inverse.ravel(), weights=np.asarray(v, dtype=float).ravel(),
                        minlength=idx.size)
        with np.errstate(over="ignore", invalid="ignore"):  # checked on the result below
            right = np.ascontiguousarray(self._right[idx].T)
            if SYMMETRIC_MIN_SHARE * self.n > idx.size:  # the tiles would save too little
                result = self._rows_times(self._left, right, v)
            else:
                result = np.empty(self.n)
                others = np.ones(self.n, dtype=bool)
                others[idx] = False
                result[others] = self._rows_times(self._left[others], right, v)
                result[idx] = self._symmetric_times(self._left[idx], right, v)
        require_finite_kernel(result, self.parameters["kernel"])
        return result

    def _finish(self, block: NDArray[np.float64]) -> None:
        finish_in_place(block, self.parameters["kernel"], self.parameters["degree"],
                        in_product=True)

    def _rows_times(self, left: NDArray[np.float64], right: NDArray[np.float64],
                    v: NDArray[np.float64]) -> NDArray[np.float64]:
        r""":math:`k(\text{rows}, idx)\,v` for the rows
        whose left factor is ``left``, in row blocks."""
        rows = max(1, PRODUCT_BLOCK_ENTRIES // max(right.shape[1], 1))
        buffer, result = np.empty(min(rows,
                                      left.shape[0]) * right.shape[1]), np.empty(left.shape[0])
        for start in range(0, left.shape[0], rows):
            block = buffer[:min(rows,
                                left.shape[0] - start) * right.shape[1]].reshape(-1, right.shape[1])
            np.matmul(left[start:start + block.shape[0]], right, out=block)
            self._finish(block)
            np.matmul(block, v, out=result[start:start + block.shape[0]])
        return result

    def _symmetric_times(self, left: NDArray[np.float64], right: NDArray[np.float64],
                         v: NDArray[np.float64]) -> NDArray[np.float64]:
        r""":math:`K_{idx, idx}\,v` from the tiles on and
        above the diagonal only (see :meth:`products`)."""
        m = left.shape[0]
        side = max(1, math.isqrt(PRODUCT_BLOCK_ENTRIES))
        buffer, result = np.empty(min(side, m) ** 2), np.zeros(m)
        for a in range(0, m, side):
            rows = slice(a, min(a + side, m))
            for b in range(a, m, side):
                columns = slice(b, min(b + side, m))
                tile = buffer[: (rows.stop - a) * (columns.stop - b)].reshape(
                    rows.stop - a, columns.stop - b
                )
                np.matmul(left[rows], right[:, columns], out=tile)
                self._finish(tile)
                result[rows] += tile @ v[columns]
                if b > a:  # the mirrored tile below the diagonal
                    result[columns] += tile.T @ v[rows]
        return result
