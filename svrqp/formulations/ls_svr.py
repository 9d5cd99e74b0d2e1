r"""LS-SVR as a linear KKT system (S4, Lin et al. 2011, eqs. 4–7).

Primal (S4 eq. 4, error term halved as explained below):
:math:`\min_{w,b,\xi} \tfrac12 w^\top w + \tfrac{C}{2}\sum_i \xi_i^2` s.t.
:math:`y_i = w^\top\varphi(x_i) + b + \xi_i`. Eliminating :math:`w, \xi`
gives the KKT system (S4 eq. 5), with :math:`\Omega_{ij} = k(x_i, x_j)`:

.. math::

    \begin{bmatrix} 0 & \mathbf 1^\top \\ \mathbf 1 & \Omega + C^{-1} I \end{bmatrix}
    \begin{bmatrix} b \\ \alpha \end{bmatrix}
    = \begin{bmatrix} 0 \\ y \end{bmatrix},
    \qquad y(x) = \sum_i \alpha_i k(x, x_i) + b \quad\text{(S4 eq. 7)} .

**Where S4's** :math:`C\sum\xi_i^2` **became** :math:`\tfrac{C}{2}\sum\xi_i^2`. S4's eq. (4) is the
Lagrangian
:math:`\tfrac12 w^\top w + C\sum_i\xi_i^2 - \sum_i\alpha_i[w^\top\varphi(x_i) + b + \xi_i - y_i]`;
its stationarity in :math:`\xi_i` gives :math:`\alpha_i = 2C\xi_i` and so the block
:math:`\Omega + (2C)^{-1} I`, not the :math:`\Omega + C^{-1} I` that S4 prints in eq. (5). The two
equations disagree by a factor 2. This module writes the error term as
:math:`\tfrac{C}{2}\sum\xi_i^2` (the usual LS-SVM convention, Suykens' :math:`\tfrac{\gamma}{2}`),
which makes eq. (5), the system S4 actually solves, exact. What that does to C: S4's :math:`C = 0.5`
is used as the ridge :math:`C^{-1} = 2` of eq. (5); a reader taking eq. (4) literally would need
``C = 1.0`` here for the same model (in general:
literal-eq.-(4) :math:`C` equals this module's :math:`C/2`).

Solved by one Cholesky factorisation of :math:`H = \Omega + C^{-1} I` (positive definite) and
the Schur complement of the bordered system: with :math:`H\nu = \mathbf 1` and :math:`H\mu = y`,

.. math::

    b = \frac{\mathbf 1^\top \mu}{\mathbf 1^\top \nu}, \qquad \alpha = \mu - b\,\nu .

Without the bias row the system is :math:`H\alpha = y`, which is kernel ridge regression with
regularisation :math:`1/C` (scikit-learn's ``KernelRidge(alpha=1/C)``).
"""

from __future__ import annotations

import time
from importlib.metadata import version
from typing import NamedTuple

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError, SingularSystemError
from svrqp.problems import LinearSystem
from svrqp.solution import Solution, SolverRecord


class LSSVRFit(NamedTuple):
    """What :func:`solve_cholesky_schur` returns."""

    alpha: NDArray[np.float64]  #: the coefficients of S4 eq. 7
    intercept: float  #: the bias b (0 without the bias row)
    solution: Solution  #: x = [b; alpha], certified by the residual of the full system of S4 eq. 5


def _add_to_diagonal(M: NDArray[np.float64], value: float) -> None:
    r""":math:`M \leftarrow M + \text{value}\, I` in place (no n×n identity is formed)."""
    diagonal = np.einsum("ii->i", M)  # a writable view
    diagonal += value


def kkt_system(K: NDArray[np.float64], y: NDArray[np.float64], C: float,
               fit_intercept: bool = True) -> LinearSystem:
    r"""The full KKT system of S4 eq. (5) (or :math:`H\alpha = y` without the bias).

    The matrix is written once: K is copied into its block and :math:`C^{-1}` added on the diagonal.
    """
    if not np.isfinite(C) or C <= 0:
        raise ProblemError(f"C must be a finite positive number, got {C!r}")
    n = y.shape[0]
    if not fit_intercept:
        H = K.astype(float, copy=True)
        _add_to_diagonal(H, 1.0 / C)
        return LinearSystem(M=H, rhs=y, name="LS-SVR without bias", statement=r"(\Omega + "
                                                                              r"C^{-1}I)\alpha = y")
    M = np.empty((n + 1, n + 1))
    M[0, 0] = 0.0
    M[0, 1:] = 1.0
    M[1:, 0] = 1.0
    M[1:, 1:] = K
    _add_to_diagonal(M[1:, 1:], 1.0 / C)
    statement = (
        r"\begin{bmatrix}0 & \mathbf 1^\top\\ \mathbf 1 & \Omega + C^{-1}I\end{bmatrix}"
        r"\begin{bmatrix}b\\ \alpha\end{bmatrix} = \begin{bmatrix}0\\ y\end{bmatrix}"
    )
    return LinearSystem(M=M, rhs=np.concatenate([[0.0], y]), name="LS-SVR KKT system",
                        statement=statement)


def solve_cholesky_schur(
    K: NDArray[np.float64], y: NDArray[np.float64], C: float, fit_intercept: bool = True, *,
    overwrite_K: bool = False,
) -> LSSVRFit:
    r"""Solve the LS-SVR system by one in-place Cholesky
    of :math:`\Omega + I/C` and the Schur complement.

    Parameters
    ----------
    K
        Gram matrix :math:`\Omega`, symmetric, shape ``(n, n)``.
    y
        Targets, shape ``(n,)``.
    C
        Regularisation (positive).
    fit_intercept
        Solve the bordered system with the bias :math:`b` (else :math:`b = 0`).
    overwrite_K
        Factor in K's own memory (K is destroyed) instead of in one n×n copy.

    Returns
    -------
    LSSVRFit
        Coefficients, bias, and the :class:`~svrqp.solution.Solution` ``x = [b; alpha]`` whose
        residuals (``primal``, ``primal_rel``) are those of the full system (the certificate of
        this solution), backend ``"cholesky"``.
    """
    if not np.isfinite(C) or C <= 0:
        raise ProblemError(f"C must be a finite positive number, got {C!r}")
    start = time.perf_counter()
    H = K if overwrite_K and K.dtype == np.float64 else K.astype(float, order="C", copy=True)
    H_diagonal = np.diagonal(H) + 1.0 / C
    np.einsum("ii->i", H)[:] = H_diagonal
    # H is symmetric, so H.T is the same matrix in Fortran order: LAPACK factors it in place
    # (a C-ordered array would be copied) and leaves its
    # other triangle, H's strict upper part, as it was.
    try:
        factor = scipy.linalg.cho_factor(H.T, lower=False, overwrite_a=True, check_finite=False)
    except np.linalg.LinAlgError:
        raise SingularSystemError(
            "Omega + I/C is not positive definite: is the kernel PSD?"
        ) from None
    if fit_intercept:
        nu_mu = scipy.linalg.cho_solve(factor, np.column_stack([np.ones_like(y), y]),
                                       check_finite=False)
        nu, mu = nu_mu[:, 0], nu_mu[:, 1]
        # 1^T H^-1 1 > 0 for a positive definite H; anything
        # else is a factor that broke down numerically.
        if not (np.isfinite(nu_mu).all() and nu.sum() > 0):
            raise SingularSystemError("Omega + I/C is numerically singular: 1^T (Omega + I/C)^-1 1 "
                                      "is not a "
                                      "finite positive number (scale the inputs, or lower C)")
        b = float(mu.sum() / nu.sum())
        alpha = mu - b * nu
    else:
        alpha = scipy.linalg.cho_solve(factor, y, check_finite=False)
        b = 0.0
    solve_time = time.perf_counter() - start
    # Certificate of the full bordered system without forming it: rows [1^T alpha; H alpha + b 1].
    # H alpha from the untouched triangle and H's diagonal
    # put back (BLAS symv reads one triangle only).
    np.einsum("ii->i", H)[:] = H_diagonal
    H_alpha = scipy.linalg.blas.dsymv(1.0, H.T, alpha, lower=1)
    Mx = np.concatenate([[alpha.sum() if fit_intercept else 0.0], H_alpha + b])
    residual = float(np.max(np.abs(Mx - np.concatenate([[0.0], y]))))
    scale = 1.0 + max(float(np.max(np.abs(Mx))), float(np.max(np.abs(y))))
    record = SolverRecord("cholesky", f"scipy {version('scipy')}", {"fit_intercept": fit_intercept},
                          solve_time=solve_time)
    solution = Solution.of_linear_system(
        np.concatenate([[b], alpha]), {"residual": residual, "residual_rel": residual / scale},
        record,
    )
    return LSSVRFit(alpha, b, solution)
