r"""Recursive least squares with an optional forgetting factor, and the batch merge (S3).

The model is linear in its regressors, :math:`y_i = x_i^\top a + e_i` (S3 eq. (4); for a
thermal model :math:`x_i = (1, \theta_1, \dots, \theta_n)` as in S3 eq. (1)). After :math:`k`
samples the least-squares estimate is (S3 eqs. (7)–(9))

.. math::

    a_k = P_k b_k,\qquad P_k = \Bigl(\sum_{i=1}^{k} \lambda^{k-i} x_i x_i^\top\Bigr)^{-1},\qquad
    b_k = \sum_{i=1}^{k} \lambda^{k-i} x_i y_i ,

with the forgetting factor :math:`0 < \lambda \le 1` (:math:`\lambda = 1` is S3's method; a
smaller :math:`\lambda` discounts old samples so the model follows a drifting machine).

Recursion (S3 eqs. (13)–(17)), for a new sample :math:`(x_k, y_k)`:

.. math::

    K_k &= P_{k-1} x_k \bigl(\lambda + x_k^\top P_{k-1} x_k\bigr)^{-1}
        &\text{(eq. 14)}\\
    P_k &= \tfrac{1}{\lambda}\bigl(P_{k-1} - K_k x_k^\top P_{k-1}\bigr)
        &\text{(eq. 13)}\\
    a_k &= a_{k-1} - K_k\bigl(x_k^\top a_{k-1} - y_k\bigr)
        &\text{(eq. 17)}\\
    b_k &= \lambda b_{k-1} + x_k y_k
        &\text{(eq. 11)}\\
    P_k^{-1} &= \lambda P_{k-1}^{-1} + x_k x_k^\top
        &\text{(eq. 10)}

The recursion needs a starting :math:`P`; :func:`batch_state` computes it exactly from the
first samples (eqs. (20)–(21)), so no large-:math:`P_0` approximation is involved and, with
:math:`\lambda = 1`, :math:`a_k` equals the batch least-squares solution to round-off. The
first samples must determine every coefficient well: :func:`initial_prefix` finds the shortest
prefix whose equilibrated information matrix has a condition number below
:data:`START_CONDITION` (a prefix that is merely full rank — three nearly equal temperature
readings, say — would give an inaccurate :math:`P_0` that the recursion then carries along).

Residual variance (S3 eq. (19)), with :math:`S_k = \sum_i \lambda^{k-i} (y_i - x_i^\top a_k)^2`
updated exactly by :math:`S_k = \lambda S_{k-1} + \xi_k^2 \lambda/(\lambda + x_k^\top P_{k-1}
x_k)`, :math:`\xi_k = y_k - x_k^\top a_{k-1}`, and :math:`w_k = \sum_i \lambda^{k-i}` (the
sample count :math:`k` when :math:`\lambda = 1`):

.. math::

    \sigma^2 \approx \frac{S_k}{w_k - n}.

Batch merge (S3 eqs. (20)–(24)): two models fitted on separate batches keep
:math:`P(0) = (\sum x x^\top)^{-1}` and :math:`b(0) = \sum x y`; the merged model is

.. math::

    P^{-1} = P_1^{-1} + P_0^{-1},\qquad b = b_1 + b_0,\qquad a = P b ,

identical to refitting on the union (S3's eq. (24) prints ``+`` for the product). The state
carries :math:`P^{-1}` as well, accumulated by eq. (10), so the merge adds information matrices
without inverting the recursed :math:`P` back (which would cost another factor
:math:`\kappa` of round-off). The residual
sums merge exactly as :math:`S = S_0 + S_1 + \sum_{j\in\{0,1\}} (a_j - a)^\top P_j^{-1}(a_j - a)`.

Change of regressors: if :math:`\tilde x = T x` for an invertible :math:`T` (e.g. temperatures
taken relative to another reference), the same model has :math:`\tilde a = T^{-\top} a`,
:math:`\tilde b = T b`, :math:`\tilde P^{-1} = T P^{-1} T^\top`, :math:`\tilde P = T^{-\top} P
T^{-1}` and unchanged residuals (:func:`transform_regressors`); two models on differently
referenced regressors are brought to one set before they are merged.

Numerically stable form: the state carries the upper-triangular square root :math:`R_k` of the
information matrix, :math:`R_k^\top R_k = P_k^{-1}`, instead of :math:`P_k`. One step is the QR
factorisation

.. math::

    \begin{bmatrix} x_k^\top \\ \sqrt\lambda\, R_{k-1} \end{bmatrix} = Q_k \begin{bmatrix} R_k \\ 0
    \end{bmatrix}, \qquad
    \begin{bmatrix} z_k \\ \cdot \end{bmatrix} = Q_k^\top \begin{bmatrix} y_k \\ \sqrt\lambda\,
    R_{k-1} a_{k-1} \end{bmatrix}, \qquad a_k = R_k^{-1} z_k ,

which gives the same :math:`a_k` as eqs. (13)–(17) (it is the exponentially weighted least-squares
problem above, solved by orthogonal transformations) without dividing by :math:`\lambda`: the
covariance form's :math:`P_k / \lambda` grows by :math:`1/\lambda` per step and lost every digit
for :math:`\lambda = 10^{-8}`, and failed outright for :math:`10^{-30}` (issue #39). The accuracy is
about :math:`\kappa(R)\,\epsilon` rather than :math:`\kappa(P^{-1})\,\epsilon`. A forgetting factor
so small that the samples which keep a non-zero weight no longer determine every coefficient raises
:class:`~svrqp.exceptions.SingularSystemError` naming the factor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from svrqp.exceptions import ProblemError, SingularSystemError
from svrqp.formulations.least_squares import check_finite_matrix, solve_normal_equations

#: Largest condition number of the equilibrated information matrix :math:`\sum x_i x_i^\top`
#: from which the recursion is started (about half of the double-precision digits survive).
START_CONDITION = 1e8


@dataclass(frozen=True)
class RecursiveLSState:
    """Everything the recursion carries from one sample to the next.

    Attributes
    ----------
    a : ndarray of shape (p,)
        Current coefficients :math:`a_k` (eq. 7).
    R : ndarray of shape (p, p)
        Upper-triangular square root of the information matrix, :math:`R_k^\top R_k = P_k^{-1}`
        (the recursion's numerically stable form, see the module docstring); :attr:`P` is
        :math:`R_k^{-1} R_k^{-\top}`.
    b : ndarray of shape (p,)
        :math:`b_k = \\sum \\lambda^{k-i} x_i y_i` (eq. 9).
    information : ndarray of shape (p, p)
        :math:`P_k^{-1} = \\sum \\lambda^{k-i} x_i x_i^\\top` (eq. 10), used by :func:`merge`.
    n_samples : int
        Samples absorbed, :math:`k`.
    weight : float
        :math:`w_k = \\sum_i \\lambda^{k-i}` (equal to ``n_samples`` when :math:`\\lambda = 1`).
    sse : float
        Discounted residual sum of squares :math:`S_k` at :math:`a_k`.
    forgetting : float
        The forgetting factor :math:`\\lambda`.
    """

    a: np.ndarray
    R: np.ndarray
    b: np.ndarray
    information: np.ndarray
    n_samples: int
    weight: float
    sse: float
    forgetting: float

    @property
    def P(self) -> np.ndarray:
        """:math:`P_k = (R_k^\top R_k)^{-1}`, the inverse
        of the discounted information matrix (eq. 8)."""
        R_inv = scipy.linalg.solve_triangular(self.R, np.eye(self.R.shape[0]))
        return R_inv @ R_inv.T

    @property
    def sigma2(self) -> float:
        """Residual variance estimate :math:`S_k / (w_k - n)` (S3 eq. (19))."""
        dof = self.weight - self.a.size
        if dof <= 0:
            raise ProblemError(
                f"sigma² needs more samples than parameters: weight {self.weight:g} "
                f"<= {self.a.size} parameters"
            )
        return self.sse / dof


def check_forgetting(forgetting: float) -> float:
    """Return ``forgetting`` as a float in (0, 1], or raise :class:`ProblemError`."""
    value = float(forgetting)
    if not 0.0 < value <= 1.0:
        raise ProblemError(f"forgetting factor must lie in (0, 1], got {forgetting!r}")
    return value


def _spd_solve(M: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve :math:`M z = rhs` for symmetric positive definite ``M`` by an equilibrated Cholesky."""
    d = 1.0 / np.sqrt(np.diag(M))
    try:
        factor = scipy.linalg.cho_factor(M * np.outer(d, d))
    except np.linalg.LinAlgError as err:
        raise SingularSystemError(f"information matrix is not positive definite: {err}") from err
    scale = d[:, None] if rhs.ndim == 2 else d
    return scale * scipy.linalg.cho_solve(factor, scale * rhs)


def initial_prefix(X: np.ndarray, max_condition: float = START_CONDITION) -> int | None:
    """Length of the shortest prefix of ``X`` that determines every coefficient well.

    Parameters
    ----------
    X : array of shape (n, p)
        Regressor rows in arrival order.
    max_condition : float
        Largest accepted condition number of the equilibrated :math:`\\sum_{i\\le m} x_i x_i^\\top`.

    Returns
    -------
    int or None
        The smallest such :math:`m \\ge p`, or ``None`` when no prefix (not even all of ``X``)
        qualifies.
    """
    X = check_finite_matrix(X, "X", 2)
    n, p = X.shape
    if n < p:
        return None
    information = np.cumsum(X[:, :, None] * X[:, None, :], axis=0)[p - 1:]  # m = p … n
    diagonal = np.diagonal(information, axis1=1, axis2=2)
    d = 1.0 / np.sqrt(np.where(diagonal > 0, diagonal, 1.0))
    eigenvalues = np.linalg.eigvalsh(information * d[:, :, None] * d[:, None, :])
    well_determined = np.flatnonzero(eigenvalues[:, 0] * max_condition > eigenvalues[:, -1])
    return None if well_determined.size == 0 else int(well_determined[0]) + p


def batch_state(
    X: np.ndarray,
    y: np.ndarray,
    *,
    forgetting: float = 1.0,
    column_names: list[str] | None = None,
) -> RecursiveLSState:
    """Batch least squares as a recursion state: :math:`P(0)`, :math:`b(0)` (S3 eqs. (20)–(21)).

    With :math:`\\lambda < 1` sample :math:`i` of :math:`m` is weighted :math:`\\lambda^{m-i}`,
    exactly as if the samples had been absorbed one by one.

    Raises
    ------
    ProblemError
        NaN/inf, shape mismatch, fewer samples than parameters, bad forgetting factor.
    SingularSystemError
        The regressors are linearly dependent (e.g. a constant sensor next to the constant 1).
    """
    forgetting = check_forgetting(forgetting)
    X = check_finite_matrix(X, "X", 2)
    y = check_finite_matrix(y, "y", 1)
    m = X.shape[0]
    if y.shape[0] != m:
        raise ProblemError(f"X has {m} rows but y has {y.shape[0]} values")
    if m < X.shape[1]:
        raise ProblemError(f"fewer samples than parameters: {m} sample(s) for {X.shape[1]} "
                           "parameters, the least-squares problem is underdetermined")
    weights = forgetting ** np.arange(m - 1, -1, -1, dtype=float)
    root = np.sqrt(weights)
    # the exact normal equations name the dependent columns of a singular design
    if forgetting == 1.0:
        solve_normal_equations(X, y, column_names=column_names)
    R, z = _weighted_factor(X, y, root, forgetting, column_names)
    a = scipy.linalg.solve_triangular(R, z)
    residual = y - X @ a
    information = (X * weights[:, None]).T @ X
    return RecursiveLSState(
        a=a,
        R=R,
        b=X.T @ (weights * y),
        information=information,
        n_samples=m,
        weight=float(weights.sum()),
        sse=float(weights @ residual**2),
        forgetting=forgetting,
    )


def _weighted_factor(X: np.ndarray, y: np.ndarray, root: np.ndarray, forgetting: float,
                     column_names: list[str] | None) -> tuple[np.ndarray, np.ndarray]:
    r"""Upper-triangular :math:`R` with :math:`R^\top R = \sum_i \lambda^{m-i} x_i x_i^\top` and
    :math:`z = Q^\top y_w`, so that :math:`a = R^{-1} z`: a QR factorisation of the weighted rows,
    newest (heaviest) first, with equilibrated columns. Raises :class:`SingularSystemError` when the
    weighted rows are rank deficient (a forgetting
    factor so small that too few rows keep a weight)."""
    weighted = (X * root[:, None])[::-1]
    norms = np.linalg.norm(weighted, axis=0)
    scale = 1.0 / np.where(norms > 0, norms, 1.0)
    Q, R_scaled = np.linalg.qr(weighted * scale)
    singular = np.linalg.svd(R_scaled, compute_uv=False)
    p = X.shape[1]
    if singular.size < p or not singular[-1] > max(X.shape) * np.finfo(float).eps * singular[0]:
        names = column_names if column_names is not None else [f"x{j}" for j in range(p)]
        raise SingularSystemError(
            f"the regressors {names} weighted by the forgetting factor {forgetting:g} (sample i of "
            f"{len(X)} weighted {forgetting:g}^(m-i)) are rank deficient: the samples that keep a "
            "weight do not determine every coefficient; use a larger forgetting factor or more "
            "varied samples")
    return R_scaled / scale[None, :], Q.T @ (y * root)[::-1]


def update(state: RecursiveLSState, x: np.ndarray, y: float) -> RecursiveLSState:
    """Absorb one sample :math:`(x_k, y_k)` by S3 eqs. (13), (14), (17) and (11)."""
    x = check_finite_matrix(x, "x", 1)
    y = float(y)
    if not np.isfinite(y):
        raise ProblemError(f"y is not finite: {y}")
    if x.size != state.a.size:
        raise ProblemError(f"x has {x.size} regressors, the model has {state.a.size}")
    lam = state.forgetting
    root = np.sqrt(lam)
    w = scipy.linalg.solve_triangular(state.R, x, trans="T")  # R⁻ᵀx: xᵀ P x = ‖w‖²
    denominator = lam + float(w @ w)
    prior_error = y - float(x @ state.a)
    # Square-root form of eqs. (13)-(17): the QR factor of [xᵀ; √λ R] is the new R, and the same
    # rotation applied to [y; √λ R a] gives z with a = R⁻¹ z. Nothing is divided by λ, so a tiny
    # forgetting factor (1e-8, 1e-30) cannot blow P up the way the covariance form (eq. 13) does.
    Q, R = np.linalg.qr(np.vstack([x[None, :], root * state.R]))
    z = Q.T @ np.concatenate([[y], root * (state.R @ state.a)])
    return RecursiveLSState(
        a=scipy.linalg.solve_triangular(R, z),  # eqs. (14), (17)
        R=R,
        b=lam * state.b + x * y,  # eq. (11)
        information=lam * state.information + np.outer(x, x),  # eq. (10)
        n_samples=state.n_samples + 1,
        weight=lam * state.weight + 1.0,
        sse=lam * state.sse + prior_error**2 * lam / denominator,
        forgetting=lam,
    )


def update_batch(state: RecursiveLSState, X: np.ndarray, y: np.ndarray) -> RecursiveLSState:
    """Absorb the rows of ``X`` one after the other (the recursion, not a refit)."""
    X = check_finite_matrix(X, "X", 2)
    y = check_finite_matrix(y, "y", 1)
    if X.shape[0] != y.shape[0]:
        raise ProblemError(f"X has {X.shape[0]} rows but y has {y.shape[0]} values")
    for x_k, y_k in zip(X, y, strict=True):
        state = update(state, x_k, y_k)
    return state


def merge(first: RecursiveLSState, second: RecursiveLSState) -> RecursiveLSState:
    """Merge two batch models into the model of their union (S3 eqs. (22)–(24)).

    Both states must share the regressors and the forgetting factor; with :math:`\\lambda < 1`
    the two batches are treated as equally recent.
    """
    if first.a.size != second.a.size:
        raise ProblemError(
            f"cannot merge models with {first.a.size} and {second.a.size} regressors"
        )
    if first.forgetting != second.forgetting:
        raise ProblemError(
            f"cannot merge models with forgetting factors {first.forgetting} and "
            f"{second.forgetting}"
        )
    M = first.information + second.information  # eq. (22)
    b = first.b + second.b  # eq. (23)
    a = _spd_solve(M, b)  # eq. (24)
    sse = first.sse + second.sse + sum(
        float((part.a - a) @ part.information @ (part.a - a)) for part in (first, second)
    )
    return RecursiveLSState(
        a=a,
        R=np.linalg.qr(np.vstack([first.R, second.R]), mode="r"),
        b=b,
        information=M,
        n_samples=first.n_samples + second.n_samples,
        weight=first.weight + second.weight,
        sse=sse,
        forgetting=first.forgetting,
    )


def transform_regressors(state: RecursiveLSState, T: np.ndarray) -> RecursiveLSState:
    """Express ``state`` in the regressors :math:`\\tilde x = T x` (the model is unchanged).

    Parameters
    ----------
    state : RecursiveLSState
    T : array of shape (p, p)
        Invertible map from the old regressors to the new ones.
    """
    T = check_finite_matrix(T, "T", 2)
    p = state.a.size
    if T.shape != (p, p):
        raise ProblemError(f"T must be {p}×{p}, got shape {T.shape}")
    try:
        T_inv = np.linalg.inv(T)
    except np.linalg.LinAlgError as err:
        raise SingularSystemError(f"the regressor map T is singular: {err}") from err
    information = T @ state.information @ T.T
    return RecursiveLSState(
        a=T_inv.T @ state.a,
        R=np.linalg.qr(state.R @ T.T, mode="r"),
        b=T @ state.b,
        information=0.5 * (information + information.T),
        n_samples=state.n_samples,
        weight=state.weight,
        sse=state.sse,
        forgetting=state.forgetting,
    )
