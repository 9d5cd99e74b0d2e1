r"""What one run of a method produced, and the certificates of a model :math:`(\beta, b)`.

Certificates of a QP are those of :meth:`QuadraticProgram.kkt_residuals` at the backend's
primal–dual point (:func:`qp_outcome`). Methods that return only :math:`(\beta, b)` (libsvm,
and the decomposition and low-rank solvers) are certified on the stacked dual (see
:mod:`svrqp.formulations.epsilon_svr`) with multipliers reconstructed from the model
(:func:`beta_certificates`):

.. math::

    \alpha = \max(-\beta, 0),\quad \alpha^* = \max(\beta, 0),\quad \lambda = b,\quad
    f = K\beta + b,\quad z_\alpha = f - y - \varepsilon,\quad z_{\alpha^*} = y - f - \varepsilon ,

which zeroes the stationarity residual by construction, so every departure from optimality
shows in the primal residual
:math:`\max(|\mathbf 1^\top\beta|, (|\beta| - C)^+)` and the duality gap

.. math::

    r_g = \sum_t z_t^+ (C - x_t) + \sum_t z_t^- x_t ,
    \qquad x = [\alpha; \alpha^*],\ z = [z_\alpha; z_{\alpha^*}],

scaled like :meth:`QuadraticProgram.kkt_residuals` (``1 +`` the largest term).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.bench.cases import BenchCase
from svrqp.formulations import epsilon_svr, epsilon_svr_certificate
from svrqp.problems import QuadraticProgram


@dataclass(frozen=True)
class Method:
    """One way of solving one problem: ``problem`` is ``"epsilon_svr"`` or ``"ls_svr"``."""

    problem: str
    formulation: str
    backend: str

    @property
    def label(self) -> str:
        """Short name used in tables and plot legends."""
        return f"{self.backend}/{self.formulation}"


@dataclass
class RunOutcome:
    """What one run produced, before it is compared with the reference.

    ``residuals`` holds the relative certificates that apply to the problem (``primal_rel``,
    and for QPs ``dual_rel`` and ``gap_rel``); ``decision`` is the model's prediction on the
    training inputs; ``objective`` the problem's own objective at the returned coefficients
    (:func:`svrqp.formulations.epsilon_svr.dual_objective` for ε-SVR).
    """

    status: str
    build_time_s: float = math.nan
    solve_time_s: float = math.nan
    total_time_s: float = math.nan
    iterations: float = math.nan
    residuals: dict[str, float] = field(default_factory=dict)
    objective: float = math.nan
    decision: NDArray[np.float64] | None = None
    support: NDArray[np.bool_] | None = None
    notes: dict[str, float] = field(default_factory=dict)
    error: str = ""


def beta_certificates(Kbeta: NDArray[np.float64], b: float, y: NDArray[np.float64],
                      beta: NDArray[np.float64], C: float, epsilon: float) -> dict[str, float]:
    """Relative certificates of a model :math:`(\\beta, b)`
    on the stacked ε-SVR dual (module docstring).

    Parameters
    ----------
    Kbeta, b
        :math:`K\\beta` on the training inputs, and the intercept.
    y, beta, C, epsilon
        Targets, dual coefficients and SVR parameters.

    Returns
    -------
    dict
        ``primal_rel``, ``dual_rel`` (zero by construction) and ``gap_rel``, scaled as
        :meth:`QuadraticProgram.kkt_residuals` scales them.
    """
    # b enters through the decision values Kβ + b, so r rounds as in the recorded benchmark results
    point = epsilon_svr_certificate.multipliers(beta, 0.0, Kbeta + b, y, epsilon)
    x = np.concatenate([point.alpha, point.alpha_star])
    z_plus = np.maximum(point.z_box, 0.0)
    balance = float(abs(beta.sum()))
    primal = max(balance, float(np.max(np.maximum(x - C, 0.0), initial=0.0)))
    quadratic = float(beta @ Kbeta)  # x^T P x
    linear = float(epsilon * np.abs(beta).sum() - y @ beta)  # q^T x (alpha_i alpha*_i = 0 here)
    upper = C * float(z_plus.sum())  # ub^T z_box^+ (lb = 0 adds nothing)
    gap = quadratic + linear + upper
    return {
        "primal_rel": primal / (1.0 + max(float(np.max(x, initial=0.0)), balance, C)),
        "dual_rel": 0.0,
        "gap_rel": abs(gap) / (1.0 + max(abs(quadratic), abs(linear), upper)),
    }


def _relative(residuals: dict[str, float]) -> dict[str, float]:
    return {key: float(residuals[key]) for key in ("primal_rel", "dual_rel", "gap_rel")
            if key in residuals}


def svr_outcome(case: BenchCase, beta: NDArray[np.float64], b: float, Kbeta: NDArray[np.float64],
                residuals: dict[str, float] | None, **fields: Any) -> RunOutcome:
    """A :class:`RunOutcome` of an ε-SVR method from its model :math:`(\\beta, b)`.

    ``residuals`` are the method's own certificates (a QP's), or ``None`` to certify the model
    with :func:`beta_certificates`.
    """
    if residuals is None:
        residuals = beta_certificates(Kbeta, b, case.y, beta, case.C, case.epsilon)
    objective = float(0.5 * beta @ Kbeta - case.y @ beta + case.epsilon * np.abs(beta).sum())
    return RunOutcome(residuals=_relative(residuals), objective=objective, decision=Kbeta + b,
                      support=epsilon_svr.support_mask(beta, case.C), **fields)


@dataclass(frozen=True)
class QPPoint:
    """A primal–dual point ``(x, y, z, z_box)`` of the QP ``problem`` of one ε-SVR formulation."""

    formulation: str
    problem: QuadraticProgram
    x: NDArray[np.float64]
    y: NDArray[np.float64] | None
    z: NDArray[np.float64] | None
    z_box: NDArray[np.float64] | None


def qp_outcome(case: BenchCase, point: QPPoint, status: str, K: NDArray[np.float64] | None,
               **fields: Any) -> RunOutcome:
    """Outcome of a QP formulation: certificates of
    ``point.problem`` at the point, model read off ``point.x``.

    This is the row evaluator's entry for QP solutions, so any ``x`` (including a perturbed one)
    is judged by its own certificates. ``K`` is the Gram matrix (``None`` for the primal form).
    """
    x = point.x
    residuals = point.problem.kkt_residuals(x, point.y, point.z, point.z_box)
    beta = epsilon_svr.beta_from_solution(point.formulation, case.n, x, point.z)
    if point.formulation == "primal":
        w, b = x[:case.d], float(x[case.d])
        Kbeta = case.X @ (case.X.T @ beta)
        # The model is w·x + b; its predictions are X w + b (equal to Kβ + b at the optimum).
        return replace(svr_outcome(case, beta, b, Kbeta, residuals, status=status, **fields),
                       decision=case.X @ w + b)
    Kbeta = K @ beta
    b = epsilon_svr.intercept_from_kkt(K, case.y, beta, case.C, case.epsilon)
    return svr_outcome(case, beta, b, Kbeta, residuals, status=status, **fields)


def ls_svr_outcome(case: BenchCase, K: NDArray[np.float64], alpha: NDArray[np.float64], b: float,
                   residual_rel: float, **fields: Any) -> RunOutcome:
    r"""LS-SVR: objective :math:`\tfrac12\alpha^\top(K + I/C)\alpha - y^\top\alpha`
    (the minimised dual)."""
    Kalpha = K @ alpha
    objective = float(0.5 * alpha @ Kalpha + 0.5 * alpha @ alpha / case.C - case.y @ alpha)
    return RunOutcome(residuals={"primal_rel": float(residual_rel)}, objective=objective,
                      decision=Kalpha + b, support=np.ones(case.n, dtype=bool), **fields)

