"""The Gram matrix as the interior point sees it: dense
(Cholesky) or factored :math:`K = LL^\top` (Woodbury)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from svrqp.exceptions import SingularSystemError


class DenseKernel:
    """An explicit Gram matrix: products by BLAS, Newton systems by dense Cholesky."""

    def __init__(self, K: NDArray[np.float64]) -> None:
        self.K = K
        # reused: fresh n×n allocations cost page faults
        self._workspace = np.empty_like(K, order="F")

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
            raise SingularSystemError(
                "K + D^-1 is not positive definite: is the kernel PSD?"
            ) from None
        return lambda rhs: scipy.linalg.cho_solve(factor, rhs, check_finite=False)


class FactoredKernel:
    """A factored kernel :math:`K = LL^\\top` (``L`` of
    shape ``(n, r)``): Woodbury solves in :math:`O(nr^2)`."""

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
        """A solver of
        :math:`(LL^\\top + \\operatorname{diag}(\\text{shift}))\\,x = \\text{rhs}` (Woodbury)."""
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
            return Drhs - d * (
                self.L @ scipy.linalg.cho_solve(factor, self.L.T @ Drhs, check_finite=False)
            )

        return solve


KernelOperator = DenseKernel | FactoredKernel
