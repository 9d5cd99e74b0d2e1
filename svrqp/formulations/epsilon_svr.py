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
  :math:`P = \operatorname{diag}(K, 0, 0)`,
  :math:`q = [-y;\ \varepsilon\mathbf 1;\ \varepsilon\mathbf 1]`,
  :math:`A = \begin{bmatrix} I & I & -I\\ \mathbf 1^\top & 0 & 0\end{bmatrix}`,
  :math:`b = 0`, :math:`lb = [-C; 0; 0]`, :math:`ub = [C; C; C]`.
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

from typing import Literal, NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from svrqp.exceptions import ProblemError
from svrqp.formulations.epsilon_svr_certificate import (
    AT_LOWER,
    AT_UPPER,
    FREE_NEGATIVE,
    FREE_POSITIVE,
    ZERO,
    kkt_violation,
    multipliers,
    states,
    std,
)
from svrqp.problems import QuadraticProgram

Formulation = Literal["stacked", "split", "primal"]
FORMULATIONS: tuple[str, ...] = ("stacked", "split", "primal")

#: Coefficients with :math:`|\beta_i| \le` ``SV_TOLERANCE``·min(C, max|β|) are not support
#: vectors (see :func:`zero_tolerance`), and those within ``SV_TOLERANCE``·C of ±C are at the
#: bound: interior-point solutions sit slightly inside the box.
SV_TOLERANCE = 1e-6

#: The rounding allowance of :func:`returned_coefficients` for coefficients whose active sets an
#: exact step settled (:func:`polish`, the crossover): 64 float64 ulps. Their zeros are exactly 0
#: and their bounds exactly ±C, up to a change of units; a free coefficient, however small, is a
#: support vector the equality :math:`\mathbf 1^\top\beta = 0` needs.
EXACT_ROUNDING = 64.0 * float(np.finfo(float).eps)

DUAL_STATEMENT = (
    r"\max_{\alpha,\alpha^*}\; -\tfrac12 (\alpha^*-\alpha)^\top K (\alpha^*-\alpha)"
    r" - \varepsilon \mathbf 1^\top(\alpha^*+\alpha) + y^\top(\alpha^*-\alpha)"
    r"\quad\text{s.t.}\quad \mathbf 1^\top(\alpha^*-\alpha)=0,\; 0\le\alpha,\alpha^*\le C"
)


def check_parameters(y: NDArray[np.float64], C: float, epsilon: float) -> None:
    """Raise :class:`ProblemError` unless ``C > 0``,
    ``epsilon >= 0`` and ``y`` is a finite 1-D array."""
    if not np.isfinite(C) or C <= 0:
        raise ProblemError(f"C must be a finite positive number, got {C!r}")
    if not np.isfinite(epsilon) or epsilon < 0:
        raise ProblemError(f"epsilon must be a finite non-negative number, got {epsilon!r}")
    if y.ndim != 1 or not np.all(np.isfinite(y)):
        raise ProblemError("y must be a finite 1-D array")


def zero_tolerance(beta: NDArray[np.float64], C: float,
                   sv_tolerance: float = SV_TOLERANCE) -> float:
    r"""Largest :math:`|\beta_i|` read as zero: ``sv_tolerance``·min(C, max|β|).

    Relative to the solution's own scale and not to C alone: at C = 1e7 the coefficients of a
    smooth fit are of order 1–100, and a cut at 1e-6·C would drop every support vector.
    """
    return sv_tolerance * min(float(C), float(np.max(np.abs(beta), initial=0.0)))


def dual_stacked(K: NDArray[np.float64], y: NDArray[np.float64], C: float,
                 epsilon: float) -> QuadraticProgram:
    r"""The dual in the stacked variables
    :math:`z = [\alpha; \alpha^*]` (see the module docstring)."""
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


def dual_split(K: NDArray[np.float64], y: NDArray[np.float64], C: float,
               epsilon: float) -> QuadraticProgram:
    r"""The dual with :math:`\beta = \alpha^* - \alpha` as an
    equality; P is :math:`\operatorname{diag}(K, 0, 0)`."""
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


def primal_linear(X: NDArray[np.float64], y: NDArray[np.float64], C: float,
                  epsilon: float) -> QuadraticProgram:
    r"""The linear-kernel primal in :math:`x = [w; b; \xi; \xi^*]`
    with sparse constraint matrices."""
    check_parameters(y, C, epsilon)
    n, d = X.shape
    eye = sp.eye(n, format="csc")
    zeros = sp.csc_matrix((n, n))
    ones = sp.csc_matrix(np.ones((n, 1)))
    Xs = sp.csc_matrix(X)
    G = sp.vstack([sp.hstack([-Xs, -ones, zeros, -eye]), sp.hstack([Xs, ones, -eye, zeros])],
                  format="csc")
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
    r""":func:`intercept_from_kkt` from the residuals
    :math:`r = y - K\beta` (no kernel matrix needed)."""
    state = states(beta, C, sv_tolerance, zero_tolerance(beta, C, sv_tolerance))
    upper_free, lower_free = state == FREE_POSITIVE, state == FREE_NEGATIVE
    if upper_free.any() or lower_free.any():
        return float(np.mean(np.concatenate([r[upper_free] - epsilon, r[lower_free] + epsilon])))
    zero, at_upper, at_lower = state == ZERO, state == AT_UPPER, state == AT_LOWER
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
    state = states(beta, C, sv_tolerance, zero_tolerance(beta, C, sv_tolerance))
    upper, lower, free = state == AT_UPPER, state == AT_LOWER, np.abs(state) == FREE_POSITIVE
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
    residual = multipliers(polished, b, K @ polished, y, epsilon).residual
    final = np.where(upper, AT_UPPER,
                     np.where(lower, AT_LOWER, np.where(free, sign, ZERO))).astype(np.int8)
    slack = kkt_tolerance * (1.0 + float(np.max(np.abs(y))))
    # the free points sit on their tube edge by
    # construction: the sets fixed by the guess are checked
    feasible = np.all(kkt_violation(residual, final, epsilon)[~free] <= slack)
    return polished if feasible else None


def dual_objective(
    K: NDArray[np.float64], y: NDArray[np.float64], beta: NDArray[np.float64], epsilon: float
) -> float:
    r"""The minimised dual objective
    :math:`\tfrac12\beta^\top K\beta - y^\top\beta + \varepsilon\lVert\beta\rVert_1`.

    Equal to the QP objective of every dual form at the optimum (where
    :math:`\alpha_i\alpha_i^* = 0`), and computable from any model's :math:`\beta` — e.g.
    scikit-learn's ``dual_coef_`` — so objectives of different solvers compare directly.
    """
    return float(0.5 * beta @ (K @ beta) - y @ beta + epsilon * np.abs(beta).sum())


def returned_coefficients(beta: NDArray[np.float64], C: float, *,
                          exact: bool = False) -> NDArray[np.float64]:
    r"""The coefficients a model keeps: β projected onto the box :math:`[-C, C]`, those within
    ``tolerance``·C of a bound set to it, those at or below :func:`zero_tolerance` set to 0.

    ``tolerance`` is :data:`SV_TOLERANCE` for a solver's approximate answer (an interior point's
    coefficients sit slightly inside the box and slightly off zero), and :data:`EXACT_ROUNDING`
    when an exact active-set step settled β (``exact``): there the states are already exact, and
    the wider cut would drop a genuine free support vector smaller than
    :math:`10^{-6}\min(C, \max|\beta|)` and unbalance :math:`\mathbf 1^\top\beta = 0` by it
    (issue 33: a free :math:`\beta_i = 5.9\cdot10^{-6}` at C = 10 failed every solver's gap
    certificate alike). The certificate
    (:func:`~svrqp.formulations.epsilon_svr_certificate.model_certificate`) is computed on these,
    so what is certified is what predicts.
    """
    sv_tolerance = EXACT_ROUNDING if exact else SV_TOLERANCE
    beta = np.clip(np.asarray(beta, dtype=float), -C, C)
    beta = np.where(np.abs(beta) >= C * (1.0 - sv_tolerance), np.sign(beta) * C, beta)
    beta[np.abs(beta) <= zero_tolerance(beta, C, sv_tolerance)] = 0.0
    return beta


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
        spread = std(y)  # np.std and np.mean without their dispatch (a small fit pays per call)
        a = spread if spread > 0 else 1.0
        return cls(float(np.add.reduce(y)) / y.size, a, min(float(C), a))

    @classmethod
    def of_targets(cls, y: NDArray[np.float64]) -> DualScaling:
        r"""The scaling of the targets alone (:math:`u = a`, so :math:`\tilde K = K`): what the
        exact paths, which form their kernel from the inputs, solve in. Their tolerances are
        absolute in the units of y; on targets of 1e-12 they accepted a model 1.5·std(y) off the
        optimum (issue #39, finding 14)."""
        m, a, _ = cls.of(y, np.inf)
        return cls(m, a, a)

    def scaled(self, y: NDArray[np.float64], C: float,
               epsilon: float) -> tuple[NDArray[np.float64], float, float]:
        r""":math:`(\tilde y, \tilde C, \tilde\varepsilon)` (the kernel becomes
        :math:`(u/a) K`, the caller's to scale)."""
        m, a, u = self
        return (y - m) / a, float(C) / u, float(epsilon) / a

    def unscaled(self, beta: NDArray[np.float64], b: float,
                 C: float) -> tuple[NDArray[np.float64], float]:
        r""":math:`(\beta, b) = (u\tilde\beta, a\tilde b + m)` in the units of the data; a
        coefficient at the scaled bound :math:`\pm\tilde C` is put at :math:`\pm C` exactly
        (:math:`u \cdot (C/u)` may miss C by a rounding, which would free it)."""
        m, a, u = self
        C_scaled = float(C) / u
        beta = np.where(np.abs(beta) >= C_scaled, np.sign(beta) * float(C), u * beta)
        return beta, a * b + m


def support_mask(beta: NDArray[np.float64], C: float,
                 sv_tolerance: float = SV_TOLERANCE) -> NDArray[np.bool_]:
    r"""Support vectors: :math:`|\beta_i| >`
    :func:`zero_tolerance` (``sv_tolerance``·min(C, max|β|))."""
    return np.abs(beta) > zero_tolerance(beta, C, sv_tolerance)
