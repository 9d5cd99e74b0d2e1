r"""The stated ε-SVR dual QP at a model :math:`(\beta, b)`,
from :math:`K\beta` alone, P never formed.

The QPs of :mod:`svrqp.formulations.epsilon_svr` touch the kernel only through :math:`Px`:

* split, :math:`x = [\beta; \alpha; \alpha^*]`: :math:`Px = [K\beta;\ 0;\ 0]`;
* stacked, :math:`x = [\alpha; \alpha^*]`: :math:`Px = [-K\beta;\ K\beta]`.

So the stated QP's residuals (:meth:`svrqp.problems.QuadraticProgram.kkt_residuals`, the same
code every backend's answer goes through) and objective are evaluated on a copy of the QP with
the stated q, b and box, whose ``P`` answers :math:`Px` with the product above and whose ``A``
is applied in :math:`O(n)` (:class:`SplitEquality`; no sparse matrix is built per fit):
:math:`K\beta` comes from the kernel columns of the support vectors only
(:math:`O(n\,n_{SV})` kernel entries instead of the :math:`O(n^2)` of building P). The point and
multipliers are those of :func:`svrqp.formulations.epsilon_svr_certificate.dual_qp_point`; the
returned model's own certificate
(:func:`svrqp.formulations.epsilon_svr_certificate.model_certificate`) is added to the residuals
by the caller, through :meth:`svrqp.solution.Solution.of_qp`.
"""

from __future__ import annotations

import copy
import functools
from typing import Any, NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError
from svrqp.formulations import epsilon_svr
from svrqp.formulations.epsilon_svr_certificate import (
    dual_qp_point,
    model_certificate,
    multipliers,
)
from svrqp.kernels import gram_diagonal
from svrqp.problems import QuadraticProgram


class KnownProduct:
    """A stand-in for a matrix whose product with one vector is already known (``M @ vector``).

    Any other operand raises :class:`ProblemError`, so a stale product can never be used.
    """

    def __init__(self, vector: NDArray[np.float64], product: NDArray[np.float64]) -> None:
        self.vector, self.product = vector, product
        self.shape = (product.size, vector.size)

    def __matmul__(self, other: Any) -> NDArray[np.float64]:
        if other is not self.vector and not np.array_equal(other, self.vector):
            raise ProblemError("KnownProduct only knows its product with the vector it was built "
                               "for")
        return self.product


class SplitEquality:
    r"""The equality matrix of the split dual, :math:`A = \begin{bmatrix} I & I & -I\\
    \mathbf 1^\top & 0 & 0\end{bmatrix}`, as the two products the certificates need.

    ``A @ x`` and ``A.T @ y`` in :math:`O(n)` without a sparse matrix: what
    :func:`svrqp.formulations.epsilon_svr.dual_split` states (its ``A`` is checked equal to this
    one's products by the tests).
    """

    def __init__(self, n: int, transposed: bool = False) -> None:
        self.n, self.transposed = n, transposed
        self.shape = (3 * n, n + 1) if transposed else (n + 1, 3 * n)

    @property
    def T(self) -> SplitEquality:  # noqa: N802 (the matrix transpose, as numpy names it)
        """:math:`A^\top`."""
        return SplitEquality(self.n, not self.transposed)

    def __matmul__(self, v: NDArray[np.float64]) -> NDArray[np.float64]:
        n = self.n
        if self.transposed:  # [y_1:n + y_n+1; y_1:n; -y_1:n]
            return np.concatenate([v[:n] + v[n], v[:n], -v[:n]])
        beta = v[:n]
        return np.append(beta + v[n:2 * n] - v[2 * n:], beta.sum())


def kernel_free_qp(formulation: str, y: NDArray[np.float64], C: float,
                   epsilon: float) -> QuadraticProgram:
    """The QP of ``formulation`` with an empty kernel
    block: q, A, b and the box as stated, P all zero."""
    if formulation not in ("split", "stacked"):
        raise ProblemError(f"formulation must be 'split' or 'stacked', got {formulation!r}")
    n = y.size
    empty = sp.csc_matrix((n, n)) if formulation == "split" else np.zeros((n, n))
    return epsilon_svr.build(formulation, y, C, epsilon, K=empty)


@functools.cache
def _template(formulation: str) -> QuadraticProgram:
    """A one-point QP of ``formulation``: its name and statement, copied by :func:`_stated_view`."""
    return kernel_free_qp(formulation, np.zeros(1), 1.0, 0.0)


def _stated_view(formulation: str, y: NDArray[np.float64], C: float, epsilon: float,
                 x: NDArray[np.float64], Px: NDArray[np.float64]) -> QuadraticProgram:
    r"""The stated QP of ``formulation`` with every vector as
    :func:`svrqp.formulations.epsilon_svr.build` writes it, ``P`` the known product :math:`Px` and
    ``A`` in :math:`O(n)` (no matrix is formed: the certificates of a fit cost :math:`O(n)`)."""
    epsilon_svr.check_parameters(y, C, epsilon)
    n = y.size
    view = copy.copy(_template(formulation))
    view.P = KnownProduct(x, Px)
    if formulation == "split":
        view.q = np.concatenate([-y, np.full(2 * n, epsilon)])
        view.A, view.b = SplitEquality(n), np.zeros(n + 1)
        view.lb = np.concatenate([np.full(n, -C), np.zeros(2 * n)])
    else:
        ones = np.ones(n)
        view.q = np.concatenate([epsilon + y, epsilon - y])
        view.A, view.b = np.concatenate([-ones, ones])[None, :], np.zeros(1)
        view.lb = np.zeros(2 * n)
    view.ub = np.full(x.size, C)
    return view


def kernel_scale(X: NDArray[np.float64], kernel_parameters: dict[str, Any]) -> float:
    """:math:`\\max_i K_{ii}` without forming K (``X`` is the Gram matrix for ``"precomputed"``)."""
    if kernel_parameters["kernel"] == "precomputed":
        return float(np.max(np.diagonal(X), initial=0.0))
    return float(np.max(gram_diagonal(np.asarray(X, dtype=float), **kernel_parameters),
                        initial=0.0))


class ModelOnQP(NamedTuple):
    """A model :math:`(\\beta, b)` written on a dual QP: what :func:`model_on_qp` returns."""

    qp: QuadraticProgram  #: the kernel-free copy whose P answers the one product P x
    #: (x, y_eq, z, z_box)
    point: tuple[NDArray[np.float64], NDArray[np.float64], None, NDArray[np.float64]]
    certificate: dict[str, float]  #: model_certificate of (beta, b)


def model_on_qp(formulation: str, y: NDArray[np.float64], C: float, epsilon: float,
                beta: NDArray[np.float64],
                b: float, Kbeta: NDArray[np.float64], scale: float) -> ModelOnQP:
    """The stated dual QP of ``formulation`` at :math:`(\\beta, b)` (module docstring).

    ``scale`` is :math:`\\max_i K_{ii}` (:func:`kernel_scale`), for the model certificate.
    ``Solution.of_qp(result.qp, result.point, record, extra_residuals=result.certificate)`` gives
    the residuals and objective every backend's answer gets.
    """
    x, y_eq, z_box = dual_qp_point(formulation, multipliers(beta, b, Kbeta, y, epsilon),
                                   float(C))
    Px = (
        np.concatenate([Kbeta, np.zeros(2 * y.size)])
        if formulation == "split"
        else np.concatenate([-Kbeta, Kbeta])
    )
    view = _stated_view(formulation, y, float(C), float(epsilon), x, Px)
    return ModelOnQP(view, (x, y_eq, None, z_box),
                     model_certificate(y, beta, Kbeta, b, C, epsilon, scale))
