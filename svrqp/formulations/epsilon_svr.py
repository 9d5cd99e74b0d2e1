r"""ε-SVR as explicit quadratic programs (S0, Miao et al. 2013).

**Primal** (S0 eq. 1–2): for training pairs :math:`(x_i, y_i)`, :math:`i = 1..n`,

.. math::

    \min_{w, b, \xi, \xi^*} \ \tfrac12 \lVert w\rVert^2 + C \sum_i (\xi_i + \xi_i^*)
    \quad\text{s.t.}\quad
    y_i - w\cdot\varphi(x_i) - b \le \varepsilon + \xi_i^*,\quad
    w\cdot\varphi(x_i) + b - y_i \le \varepsilon + \xi_i,\quad \xi, \xi^* \ge 0 .

(We attach :math:`\alpha_i^*` to the constraint that binds when :math:`y_i` lies *above* the tube,
so that :math:`\beta_i = \alpha_i^* - \alpha_i > 0` there.)

**Dual** (S0 eq. 6), with :math:`K_{ij} = k(x_i, x_j)`:

.. math::

    \max_{\alpha, \alpha^*} \ -\tfrac12 (\alpha^*-\alpha)^\top K (\alpha^*-\alpha)
    - \varepsilon\, \mathbf 1^\top(\alpha^* + \alpha) + y^\top(\alpha^* - \alpha)
    \quad\text{s.t.}\quad \mathbf 1^\top(\alpha^* - \alpha) = 0,\quad 0 \le \alpha, \alpha^* \le C .

**Decision function** (S0 eq. 3/7): :math:`f(x) = \sum_i \beta_i\, k(x_i, x) + b` with
:math:`\beta = \alpha^* - \alpha`. Sign convention: :math:`\beta` equals scikit-learn's
``SVR.dual_coef_`` (restricted to the support vectors) and ``b`` its ``intercept_``.

Three QPs state the same dual (all minimise the negated objective):

* **stacked** — :math:`z = [\alpha; \alpha^*] \in \mathbb R^{2n}`:
  :math:`P = \begin{bmatrix} K & -K\\ -K & K\end{bmatrix}`,
  :math:`q = \begin{bmatrix}\varepsilon\mathbf 1 + y\\ \varepsilon\mathbf 1 - y\end{bmatrix}`,
  :math:`A = [-\mathbf 1^\top,\ \mathbf 1^\top]`, :math:`b = 0`, :math:`lb = 0`, :math:`ub = C`.
* **split** — :math:`x = [\beta; \alpha; \alpha^*] \in \mathbb R^{3n}` with :math:`\beta` tied by an
  equality, so :math:`P` holds only the :math:`n\times n` kernel block:
  :math:`P = \operatorname{diag}(K, 0, 0)`, :math:`q = [-y;\ \varepsilon\mathbf 1;\ \varepsilon\mathbf 1]`,
  :math:`A = \begin{bmatrix} I & I & -I\\ \mathbf 1^\top & 0 & 0\end{bmatrix}`, :math:`b = 0`,
  :math:`lb = [-C; 0; 0]`, :math:`ub = [C; C; C]`.
* **primal** (linear kernel only) — :math:`x = [w; b; \xi; \xi^*]`, sparse
  :math:`P = \operatorname{diag}(I_d, 0, 0, 0)`, :math:`q = [0; 0; C\mathbf 1; C\mathbf 1]`,
  :math:`G = \begin{bmatrix} -X & -\mathbf 1 & 0 & -I\\ X & \mathbf 1 & -I & 0\end{bmatrix}`,
  :math:`h = [\varepsilon\mathbf 1 - y;\ \varepsilon\mathbf 1 + y]`, :math:`\xi, \xi^* \ge 0`.
  The dual coefficients are the multipliers: :math:`\beta = z_{1:n} - z_{n+1:2n}`.

**Bias from the KKT conditions** (complementary slackness of the primal constraints), with
:math:`r_i = y_i - (K\beta)_i`:

.. math::

    0 < \beta_i < C \Rightarrow b = r_i - \varepsilon, \qquad
    -C < \beta_i < 0 \Rightarrow b = r_i + \varepsilon .

``b`` is the mean over these free support vectors. When none is free, ``b`` is the midpoint of
the feasible interval (libsvm's rule):
:math:`\max(\{r_i - \varepsilon: \beta_i = 0\} \cup \{r_i + \varepsilon: \beta_i = -C\}) \le b \le
\min(\{r_i + \varepsilon: \beta_i = 0\} \cup \{r_i - \varepsilon: \beta_i = C\})`.

**Active-set polish.** An interior-point solution that meets a relative duality gap of
1e-8 can still be far from the optimum along directions where :math:`K` is nearly singular
(RBF Gram matrices often have eigenvalues of 1e-6). Given the sets the solver found — free
:math:`F` (sign :math:`s_F`), at the upper bound :math:`U`, at the lower bound :math:`L` — the
optimum solves the equality-constrained KKT system

.. math::

    \begin{bmatrix} K_{FF} & \mathbf 1 \\ \mathbf 1^\top & 0 \end{bmatrix}
    \begin{bmatrix} \beta_F \\ b \end{bmatrix}
    = \begin{bmatrix} y_F - \varepsilon s_F - K_{F,U} C\mathbf 1 + K_{F,L} C\mathbf 1 \\
      -C(|U| - |L|) \end{bmatrix} .

:func:`polish` solves it and keeps the result only if it satisfies every KKT condition (signs,
box, tube), so a wrong guess of the sets is never returned (OSQP's solution polishing, applied
to the SVR dual).
"""

from __future__ import annotations

from typing import Any, Literal, NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError, SolverError
from svrqp.problems import QuadraticProgram

Formulation = Literal["stacked", "split", "primal"]
FORMULATIONS: tuple[str, ...] = ("stacked", "split", "primal")

#: Coefficients with :math:`|\beta_i| \le` ``SV_TOLERANCE``·min(C, max|β|) are not support
#: vectors (see :func:`zero_tolerance`), and those within ``SV_TOLERANCE``·C of ±C are at the
#: bound: interior-point solutions sit slightly inside the box.
SV_TOLERANCE = 1e-6

DUAL_STATEMENT = (
    r"\max_{\alpha,\alpha^*}\; -\tfrac12 (\alpha^*-\alpha)^\top K (\alpha^*-\alpha)"
    r" - \varepsilon \mathbf 1^\top(\alpha^*+\alpha) + y^\top(\alpha^*-\alpha)"
    r"\quad\text{s.t.}\quad \mathbf 1^\top(\alpha^*-\alpha)=0,\; 0\le\alpha,\alpha^*\le C"
)


def check_parameters(y: NDArray[np.float64], C: float, epsilon: float) -> None:
    """Raise :class:`ProblemError` unless ``C > 0``, ``epsilon >= 0`` and ``y`` is a finite 1-D array."""
    if not np.isfinite(C) or C <= 0:
        raise ProblemError(f"C must be a finite positive number, got {C!r}")
    if not np.isfinite(epsilon) or epsilon < 0:
        raise ProblemError(f"epsilon must be a finite non-negative number, got {epsilon!r}")
    if y.ndim != 1 or not np.all(np.isfinite(y)):
        raise ProblemError("y must be a finite 1-D array")


def zero_tolerance(beta: NDArray[np.float64], C: float, sv_tolerance: float = SV_TOLERANCE) -> float:
    r"""Largest :math:`|\beta_i|` read as zero: ``sv_tolerance``·min(C, max|β|).

    Relative to the solution's own scale and not to C alone: at C = 1e7 the coefficients of a
    smooth fit are of order 1–100, and a cut at 1e-6·C would drop every support vector.
    """
    return sv_tolerance * min(float(C), float(np.max(np.abs(beta), initial=0.0)))


def dual_stacked(K: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float) -> QuadraticProgram:
    r"""The dual in the stacked variables :math:`z = [\alpha; \alpha^*]` (see the module docstring)."""
    check_parameters(y, C, epsilon)
    n = y.shape[0]
    ones = np.ones(n)
    return QuadraticProgram(
        P=np.block([[K, -K], [-K, K]]),
        q=np.concatenate([epsilon * ones + y, epsilon * ones - y]),
        A=np.concatenate([-ones, ones])[None, :],
        b=np.zeros(1),
        lb=np.zeros(2 * n),
        ub=np.full(2 * n, float(C)),
        name="epsilon-SVR dual, stacked form z = [alpha; alpha*]",
        statement=DUAL_STATEMENT,
        check_psd=False,  # PSD iff K is; the caller checked K
    )


def dual_split(K: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float) -> QuadraticProgram:
    r"""The dual with :math:`\beta = \alpha^* - \alpha` as an equality; P is :math:`\operatorname{diag}(K, 0, 0)`."""
    check_parameters(y, C, epsilon)
    n = y.shape[0]
    eye = sp.eye(n, format="csc")
    zeros = sp.csc_matrix((n, n))
    A = sp.vstack([
        sp.hstack([eye, eye, -eye]),
        sp.hstack([sp.csc_matrix(np.ones((1, n))), sp.csc_matrix((1, 2 * n))]),
    ], format="csc")
    return QuadraticProgram(
        P=sp.block_diag([sp.csc_matrix(K), zeros, zeros], format="csc"),
        q=np.concatenate([-y, np.full(2 * n, float(epsilon))]),
        A=A,
        b=np.zeros(n + 1),
        lb=np.concatenate([np.full(n, -float(C)), np.zeros(2 * n)]),
        ub=np.full(3 * n, float(C)),
        name="epsilon-SVR dual, split form x = [beta; alpha; alpha*]",
        statement=DUAL_STATEMENT + r",\qquad \beta = \alpha^* - \alpha",
        check_psd=False,
    )


def primal_linear(X: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float) -> QuadraticProgram:
    r"""The linear-kernel primal in :math:`x = [w; b; \xi; \xi^*]` with sparse constraint matrices."""
    check_parameters(y, C, epsilon)
    n, d = X.shape
    eye = sp.eye(n, format="csc")
    zeros = sp.csc_matrix((n, n))
    ones = sp.csc_matrix(np.ones((n, 1)))
    Xs = sp.csc_matrix(X)
    G = sp.vstack([sp.hstack([-Xs, -ones, zeros, -eye]), sp.hstack([Xs, ones, -eye, zeros])], format="csc")
    return QuadraticProgram(
        P=sp.diags(np.concatenate([np.ones(d), np.zeros(1 + 2 * n)]), format="csc"),
        q=np.concatenate([np.zeros(d + 1), np.full(2 * n, float(C))]),
        G=G,
        h=np.concatenate([epsilon - y, epsilon + y]),
        lb=np.concatenate([np.full(d + 1, -np.inf), np.zeros(2 * n)]),
        ub=np.full(d + 1 + 2 * n, np.inf),
        name="epsilon-SVR primal, linear kernel x = [w; b; xi; xi*]",
        statement=(
            r"\min_{w,b,\xi,\xi^*}\; \tfrac12\lVert w\rVert^2 + C\mathbf 1^\top(\xi+\xi^*)"
            r"\quad\text{s.t.}\quad y - Xw - b\mathbf 1 \le \varepsilon\mathbf 1 + \xi^*,\;"
            r" Xw + b\mathbf 1 - y \le \varepsilon\mathbf 1 + \xi,\; \xi,\xi^*\ge 0"
        ),
        check_psd=False,  # a 0/1 diagonal
    )


def build(
    formulation: str,
    y: NDArray[np.float64],
    C: float,
    epsilon: float,
    *,
    K: NDArray[np.float64] | None = None,
    X: NDArray[np.float64] | None = None,
) -> QuadraticProgram:
    """Build the QP of one formulation (``K`` for the duals, ``X`` for the primal)."""
    if formulation == "stacked":
        return dual_stacked(K, y, C, epsilon)
    if formulation == "split":
        return dual_split(K, y, C, epsilon)
    if formulation == "primal":
        return primal_linear(X, y, C, epsilon)
    raise ProblemError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")


def beta_from_solution(
    formulation: str, n: int, x: NDArray[np.float64], z: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    r"""Dual coefficients :math:`\beta = \alpha^* - \alpha` from a solution of ``formulation``."""
    if formulation == "stacked":
        return x[n:] - x[:n]
    if formulation == "split":
        return x[:n].copy()
    if formulation == "primal":
        if z is None:
            raise ProblemError("the primal formulation needs the inequality multipliers z")
        return z[:n] - z[n:]
    raise ProblemError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")


def intercept_from_kkt(
    K: NDArray[np.float64],
    y: NDArray[np.float64],
    beta: NDArray[np.float64],
    C: float,
    epsilon: float,
    sv_tolerance: float = SV_TOLERANCE,
) -> float:
    """Bias ``b`` from the KKT conditions: mean over free SVs, else the feasible midpoint."""
    return intercept_from_residual(y - K @ beta, beta, C, epsilon, sv_tolerance)


def intercept_from_residual(
    r: NDArray[np.float64],
    beta: NDArray[np.float64],
    C: float,
    epsilon: float,
    sv_tolerance: float = SV_TOLERANCE,
) -> float:
    r""":func:`intercept_from_kkt` from the residuals :math:`r = y - K\beta` (no kernel matrix needed)."""
    small, bound = zero_tolerance(beta, C, sv_tolerance), sv_tolerance * C
    upper_free = (beta > small) & (beta < C - bound)
    lower_free = (beta < -small) & (beta > -C + bound)
    if upper_free.any() or lower_free.any():
        return float(np.mean(np.concatenate([r[upper_free] - epsilon, r[lower_free] + epsilon])))
    zero = np.abs(beta) <= small
    at_upper = beta >= C - bound
    at_lower = beta <= -C + bound
    low = np.concatenate([r[zero] - epsilon, r[at_lower] + epsilon])
    high = np.concatenate([r[zero] + epsilon, r[at_upper] - epsilon])
    low_bound = low.max() if low.size else -np.inf
    high_bound = high.min() if high.size else np.inf
    if not np.isfinite(low_bound):
        return float(high_bound)
    if not np.isfinite(high_bound):
        return float(low_bound)
    return float(0.5 * (low_bound + high_bound))


def polish(
    K: NDArray[np.float64],
    y: NDArray[np.float64],
    beta: NDArray[np.float64],
    C: float,
    epsilon: float,
    sv_tolerance: float = SV_TOLERANCE,
    kkt_tolerance: float = 1e-9,
    max_refinements: int = 5,
) -> NDArray[np.float64] | None:
    """Active-set polish of an approximate dual solution (see the module docstring).

    A free coefficient whose polished value changes sign is moved to the zero set, one that
    leaves the box is moved to its bound, and the system is solved again (at most
    ``max_refinements`` times): interior-point solvers leave near-zero coefficients just above
    any fixed threshold.

    Returns the polished :math:`\beta`, or ``None`` when there is no free support vector or the
    polished point violates a KKT condition by more than ``kkt_tolerance`` (relative to
    ``1 + max |y|``), in which case the caller keeps the solver's solution.
    """
    small, bound = zero_tolerance(beta, C, sv_tolerance), sv_tolerance * C
    upper = beta >= C - bound
    lower = beta <= -C + bound
    free = ~upper & ~lower & (np.abs(beta) > small)
    sign = np.sign(beta)
    for _ in range(max_refinements):
        if not free.any():
            return None
        fixed = np.where(upper, C, np.where(lower, -C, 0.0))
        m = int(free.sum())
        M = np.zeros((m + 1, m + 1))
        M[:m, :m] = K[np.ix_(free, free)]
        M[:m, m] = 1.0
        M[m, :m] = 1.0
        rhs = np.concatenate([y[free] - epsilon * sign[free] - K[free] @ fixed, [-fixed.sum()]])
        try:
            solution = np.linalg.solve(M, rhs)
        except np.linalg.LinAlgError:
            return None
        polished = fixed.copy()
        polished[free] = solution[:m]
        flipped = free & (np.sign(polished) != sign)
        outside = free & (np.abs(polished) > C)
        if not (flipped.any() or outside.any()):
            break
        free &= ~(flipped | outside)
        upper |= outside & (sign > 0)
        lower |= outside & (sign < 0)
    else:
        return None
    b = solution[m]
    r = y - K @ polished - b  # residual of the fit at each training point
    slack = kkt_tolerance * (1.0 + float(np.max(np.abs(y))))
    zero = ~free & ~upper & ~lower
    feasible = (
        np.all(np.abs(r[zero]) <= epsilon + slack)
        and np.all(r[upper] >= epsilon - slack)
        and np.all(r[lower] <= -epsilon + slack)
    )
    return polished if feasible else None


def dual_objective(
    K: NDArray[np.float64], y: NDArray[np.float64], beta: NDArray[np.float64], epsilon: float
) -> float:
    r"""The minimised dual objective :math:`\tfrac12\beta^\top K\beta - y^\top\beta + \varepsilon\lVert\beta\rVert_1`.

    Equal to the QP objective of every dual form at the optimum (where
    :math:`\alpha_i\alpha_i^* = 0`), and computable from any model's :math:`\beta` — e.g.
    scikit-learn's ``dual_coef_`` — so objectives of different solvers compare directly.
    """
    return float(0.5 * beta @ (K @ beta) - y @ beta + epsilon * np.abs(beta).sum())


def dual_qp_point(formulation: str, K: NDArray[np.float64], y: NDArray[np.float64], beta: NDArray[np.float64],
                  b: float, epsilon: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    r"""The primal point and multipliers ``(x, y_eq, z_box)`` of a dual QP at the ε-SVR solution ``(β, b)``.

    With :math:`\alpha = \max(-\beta, 0)`, :math:`\alpha^* = \max(\beta, 0)` and the residual
    :math:`r = y - K\beta - b`, the stationarity rows of the QPs of this module (qpsolvers' signs)
    hold with

    * split, :math:`x = [\beta; \alpha; \alpha^*]`: equality multipliers :math:`[r;\ b]`, box
      multipliers :math:`[0;\ -\varepsilon - r;\ r - \varepsilon]`;
    * stacked, :math:`x = [\alpha; \alpha^*]`: equality multiplier :math:`b`, box multipliers
      :math:`[-\varepsilon - r;\ r - \varepsilon]`.

    The box multipliers have the signs the bounds need exactly when :math:`(\beta, b)` satisfies
    the ε-SVR KKT conditions, so the QP's residuals certify the solution independently of how
    it was found.
    """
    r = y - K @ beta - b
    alpha, alpha_star = np.maximum(-beta, 0.0), np.maximum(beta, 0.0)
    box = np.concatenate([-epsilon - r, r - epsilon])
    if formulation == "split":
        return np.concatenate([beta, alpha, alpha_star]), np.append(r, b), np.concatenate([np.zeros_like(beta), box])
    if formulation == "stacked":
        return np.concatenate([alpha, alpha_star]), np.array([b]), box
    raise ProblemError(f"formulation must be one of ('split', 'stacked'), got {formulation!r}")


def returned_coefficients(beta: NDArray[np.float64], C: float,
                          sv_tolerance: float = SV_TOLERANCE) -> NDArray[np.float64]:
    r"""The coefficients a model keeps: β projected onto the box :math:`[-C, C]`, those within
    ``sv_tolerance``·C of a bound set to it, those at or below :func:`zero_tolerance` set to 0.

    The certificate (:func:`model_certificate`) is computed on these, so what is certified is
    what predicts.
    """
    beta = np.clip(np.asarray(beta, dtype=float), -C, C)
    beta = np.where(np.abs(beta) >= C * (1.0 - sv_tolerance), np.sign(beta) * C, beta)
    beta[np.abs(beta) <= zero_tolerance(beta, C, sv_tolerance)] = 0.0
    return beta


#: Rounding allowance of :func:`model_certificate`, in units of the float64 machine epsilon.
ROUNDING_ULPS = 64.0


def model_certificate(y: NDArray[np.float64], beta: NDArray[np.float64], K_beta: NDArray[np.float64], b: float,
                      C: float, epsilon: float, kernel_scale: float) -> dict[str, float]:
    r"""How far a returned model :math:`(\beta, b)` is from the ε-SVR optimality conditions, in the
    units of the problem (not of C).

    With :math:`r = y - K\beta - b`, :math:`k = \max_i K_{ii}` (``kernel_scale``) and
    :math:`s_y = \operatorname{std}(y)` (:math:`\max|y|` or 1 for a constant ``y``):

    .. math::

        \text{box} = \max_i (|\beta_i| - C)^+ / C, \qquad
        \text{balance} = k\,\lvert \mathbf 1^\top\beta \rvert / s_y, \qquad
        \text{kkt} = \max_i v_i / s_y,

    where :math:`v_i` is the violation, in units of y, of the conditions of S0 eq. 6 at point i:
    :math:`|r_i| \le \varepsilon` where :math:`\beta_i = 0`; :math:`r_i \ge \varepsilon` where
    :math:`\beta_i > 0` and :math:`r_i \le \varepsilon` where :math:`\beta_i < C` (mirrored for
    :math:`\beta_i < 0`). A condition of a non-zero coefficient counts at most what moving that
    coefficient to 0 or to its bound would change in the predictions (:math:`|\beta_i| k` or
    :math:`(C - |\beta_i|) k`), so a coefficient that is merely tiny or merely near its bound is
    not a violation, while a dropped support vector (:math:`\beta_i = 0` outside the tube) is.
    A model with every value at most δ is optimal for targets within about δ·s_y of y.
    """
    beta = np.asarray(beta, dtype=float)
    r = y - K_beta - b
    spread = float(np.std(y))
    s_y = spread if spread > 0 else (float(np.max(np.abs(y))) or 1.0)
    k = kernel_scale if kernel_scale > 0 else 1.0
    magnitude = np.abs(beta)
    sign = np.sign(beta)
    signed_r = sign * r  # > epsilon: outside the tube on the coefficient's side
    inside = np.maximum(np.abs(r) - epsilon, 0.0)
    below = np.minimum(np.maximum(epsilon - signed_r, 0.0), magnitude * k)
    above = np.minimum(np.maximum(signed_r - epsilon, 0.0), np.maximum(C - magnitude, 0.0) * k)
    violation = np.where(beta == 0.0, inside, np.maximum(below, above))
    l1 = float(magnitude.sum())
    rounding = ROUNDING_ULPS * np.finfo(float).eps * (float(np.max(np.abs(y), initial=0.0)) + abs(b) + k * l1)
    return {
        "box_rel": float(np.max(np.maximum(magnitude - C, 0.0), initial=0.0)) / C,
        "balance_rel": max(k * abs(float(beta.sum())) - rounding, 0.0) / s_y,
        "kkt_rel": max(float(np.max(violation, initial=0.0)) - rounding, 0.0) / s_y,
    }


def require_model_certificate(certificate: dict[str, float], check_tol: float, backend: str) -> None:
    """Raise :class:`~svrqp.exceptions.SolverError` naming ``backend`` when a value of
    :func:`model_certificate` exceeds ``check_tol`` (NaN included)."""
    failed = [key for key, value in certificate.items() if not value <= check_tol]
    if failed:
        worst = failed[0]
        raise SolverError(f"backend {backend!r} returned a model that misses the ε-SVR optimality conditions: "
                          f"its {worst[:-4]} certificate is {certificate[worst]:.2e} (relative) > {check_tol:.1e}",
                          backend, "inaccurate")


class DualScaling(NamedTuple):
    r"""The change of units under which a dual QP is handed to a backend.

    The ε-SVR dual is homogeneous: with :math:`y = a\tilde y + m` and :math:`\beta = u\tilde\beta`,
    dividing its objective by :math:`a u` leaves the same dual in :math:`\tilde\beta` with
    :math:`\tilde K = (u/a) K`, :math:`\tilde\varepsilon = \varepsilon / a`,
    :math:`\tilde C = C/u` (the shift m drops out through :math:`\mathbf 1^\top\beta = 0`), and
    :math:`b = a\tilde b + m`. With :math:`a = \operatorname{std}(y)` and :math:`u = \min(C, a)`
    the backend sees targets of order 1 and a box no narrower than :math:`[-1, 1]`, whatever the
    units of y and the size of C: an interior point with an absolute tolerance of 1e-8 can
    resolve neither a box of width 1e-8 nor targets of order 1e-6. The kernel keeps its own
    scale (normalising a degree-20 polynomial kernel to 1 leaves entries of 1e-20 that stall
    some backends).
    """

    shift: float  #: m
    y_scale: float  #: a
    beta_scale: float  #: u

    @classmethod
    def of(cls, y: NDArray[np.float64], C: float) -> DualScaling:
        """The scaling for targets ``y`` and box bound ``C``."""
        spread = float(np.std(y))
        a = spread if spread > 0 else 1.0
        return cls(float(np.mean(y)), a, min(float(C), a))


def _certified_solution(problem: QuadraticProgram, formulation: str, K: NDArray[np.float64],
                        y: NDArray[np.float64], beta: NDArray[np.float64], b: float, epsilon: float,
                        check_tol: float, backend: str, record: Any) -> Any:
    """The :class:`~svrqp.solution.Solution` of ``problem`` at the returned model, its QP residuals
    and its :func:`model_certificate` checked; ``record`` (a Solution of the scaled QP) gives
    the backend's settings, times and iterations."""
    from svrqp.solution import Solution, require_certificates

    C = float(problem.ub[0])
    x, y_eq, z_box = dual_qp_point(formulation, K, y, beta, b, epsilon)
    residuals = problem.kkt_residuals(x, y_eq, None, z_box)
    residuals.update(model_certificate(y, beta, K @ beta, b, C, epsilon, float(np.max(np.diagonal(K), initial=0.0))))
    solution = Solution(x=x, y=y_eq, z=None, z_box=z_box, objective=problem.objective(x), status="optimal",
                        residuals=residuals, backend=backend, backend_version=record.backend_version,
                        settings=record.settings, build_time=record.build_time, solve_time=record.solve_time,
                        iterations=record.iterations)
    require_certificates(solution, problem, check_tol)
    require_model_certificate({key: residuals[key] for key in ("box_rel", "balance_rel", "kkt_rel")},
                              check_tol, backend)
    return solution


class DualFit(NamedTuple):
    """What :func:`solve_dual` returns."""

    beta: NDArray[np.float64]  #: all n coefficients, alpha* - alpha (as returned: see returned_coefficients)
    b: float  #: the bias from the KKT conditions
    problem: QuadraticProgram  #: the QP that was solved (in the units of the data)
    solution: Any  #: its certificate-checked svrqp.solution.Solution, at the returned (beta, b)
    polished: bool  #: whether polish() replaced the solver's coefficients


def certified_dual_fit(problem: QuadraticProgram, formulation: str, K: NDArray[np.float64],
                       y: NDArray[np.float64], beta: NDArray[np.float64], epsilon: float, check_tol: float,
                       backend: str, record: Any, polished: bool) -> DualFit:
    r"""Round β to the coefficients a model keeps (:func:`returned_coefficients`), read b off
    the KKT conditions and certify both on ``problem`` (:func:`_certified_solution`)."""
    C = float(problem.ub[0])
    beta = returned_coefficients(beta, C)
    b = intercept_from_kkt(K, y, beta, C, epsilon)
    solution = _certified_solution(problem, formulation, K, y, beta, b, epsilon, check_tol, backend, record)
    return DualFit(beta, b, problem, solution, polished)


def solve_dual(
    K: NDArray[np.float64],
    y: NDArray[np.float64],
    C: float,
    epsilon: float,
    *,
    formulation: str = "split",
    backend: str = "clarabel",
    tol: float = 1e-8,
    check_tol: float | None = None,
    initvals: NDArray[np.float64] | None = None,
) -> DualFit:
    r"""Build a dual QP, solve it in well-scaled units, polish it, and read off :math:`\beta` and ``b``.

    The one sequence every dual fit goes through (the estimators and the tuning loops). The
    backend solves the QP of :class:`DualScaling` (its settings record the scaling under
    ``"scaling"``); the coefficients are mapped back, rounded to what the model keeps, and
    certified on the QP in the units of the data (``problem``, also returned): its relative
    residuals and :func:`model_certificate` must be at most ``check_tol`` (default 100·tol),
    otherwise :class:`~svrqp.exceptions.SolverError` names the backend. ``initvals`` is a
    solution of that QP (e.g. a previous ``DualFit.solution.x``).
    """
    from svrqp.solvers.qp_backends import (  # the solver layer sits above the formulations
        DEFAULT_CHECK_FACTOR,
        solve_qp,
    )

    check_parameters(y, C, epsilon)
    C, epsilon = float(C), float(epsilon)
    check_tol = DEFAULT_CHECK_FACTOR * tol if check_tol is None else float(check_tol)
    problem = build(formulation, y, C, epsilon, K=K)
    m, a, u = scaling = DualScaling.of(y, C)
    K_scaled, y_scaled, C_scaled, epsilon_scaled = (K if u == a else (u / a) * K), (y - m) / a, C / u, epsilon / a
    scaled = build(formulation, y_scaled, C_scaled, epsilon_scaled, K=K_scaled)
    record = solve_qp(scaled, backend, tol=tol, check_tol=check_tol,
                      initvals=None if initvals is None else np.asarray(initvals, dtype=float) / u)
    record.settings["scaling"] = scaling._asdict()
    beta_scaled = beta_from_solution(formulation, y.shape[0], record.x)
    polished = polish(K_scaled, y_scaled, beta_scaled, C_scaled, epsilon_scaled)
    if polished is None:
        # The exact crossover of svrqp.solvers.dual_ipm: polish guesses the active sets once, the
        # crossover corrects them (coefficients a few 1e-6·C inside a bound, for instance).
        from svrqp.solvers.dual_ipm.crossover import crossover

        exact = crossover(lambda idx: K_scaled[:, idx], y_scaled, C_scaled, epsilon_scaled, beta_scaled)
        polished = exact.beta if exact.exact else None
    beta = u * (beta_scaled if polished is None else polished)
    return certified_dual_fit(problem, formulation, K, y, beta, epsilon, check_tol, backend, record,
                              polished is not None)


def support_mask(beta: NDArray[np.float64], C: float, sv_tolerance: float = SV_TOLERANCE) -> NDArray[np.bool_]:
    r"""Support vectors: :math:`|\beta_i| >` :func:`zero_tolerance` (``sv_tolerance``·min(C, max|β|))."""
    return np.abs(beta) > zero_tolerance(beta, C, sv_tolerance)
