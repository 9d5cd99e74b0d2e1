r"""A kernel dual QP solved by a stock backend and certified: the sequence every dual fit ends in.

:func:`solve_dual` builds the split or stacked dual of :mod:`svrqp.formulations.epsilon_svr`,
hands it to a backend in the units of :class:`~svrqp.formulations.epsilon_svr.DualScaling`,
settles the active sets (:func:`~svrqp.formulations.epsilon_svr.polish`, else the exact
crossover of :mod:`svrqp.solvers.dual_ipm`), and :func:`certified_dual_fit` rounds the
coefficients to what the model keeps, reads b off the KKT conditions and certifies both on the
QP in the units of the data (:mod:`svrqp.formulations.epsilon_svr_certificate`). The other exact
paths (``dual_ipm``, ``auto``) end in the same :class:`DualFit`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from svrqp.formulations.epsilon_svr import (
    DualScaling,
    beta_from_solution,
    build,
    check_parameters,
    intercept_from_kkt,
    polish,
    returned_coefficients,
)
from svrqp.formulations.epsilon_svr_certificate import (
    dual_qp_point,
    model_certificate,
    multipliers,
    require_model_certificate,
)
from svrqp.problems import QuadraticProgram
from svrqp.solution import (
    Solution,
    SolverRecord,
    check_limit,
    rejected_coefficients,
    require_certificates,
)
from svrqp.solvers import qp_backends
from svrqp.solvers.dual_ipm.crossover import DenseColumns, crossover


@dataclass(frozen=True, eq=False)
class DualProblem:
    """An ε-SVR dual in the units of the data, and the QP statement ``qp`` it is certified on."""

    formulation: str  #: "split" or "stacked"
    K: NDArray[np.float64]
    y: NDArray[np.float64]
    C: float
    epsilon: float
    qp: QuadraticProgram  #: build(formulation, y, C, epsilon, K=K)

    @classmethod
    def of(cls, formulation: str, K: NDArray[np.float64], y: NDArray[np.float64], C: float,
           epsilon: float) -> DualProblem:
        """The dual of ``formulation`` for K, y, C and ε, with its QP built."""
        C, epsilon = float(C), float(epsilon)
        return cls(formulation, K, y, C, epsilon, build(formulation, y, C, epsilon, K=K))


@dataclass(frozen=True)
class DualSettings:
    """How a dual is solved and certified (:func:`solve_dual`,
    :func:`svrqp.solvers.dual_ipm.certified.solve_dual_ipm`,
    :func:`svrqp.solvers.auto.solve_auto`)."""

    formulation: str = "split"  #: the QP statement solved and certified on ("split" or "stacked")
    tol: float = 1e-8  #: requested accuracy
    #: largest relative certificate accepted (None: 100·tol, see check_limit)
    check_tol: float | None = None


def _certified_solution(dual: DualProblem, beta: NDArray[np.float64], b: float,
                        record: SolverRecord, check_tol: float) -> Solution:
    """The :class:`~svrqp.solution.Solution` of ``dual.qp`` at the returned model, its QP residuals
    and its :func:`~svrqp.formulations.epsilon_svr_certificate.model_certificate` checked;
    ``record`` gives the backend, its settings, times and iterations."""
    Kbeta = dual.K @ beta
    x, y_eq, z_box = dual_qp_point(dual.formulation,
                                   multipliers(beta, b, Kbeta, dual.y, dual.epsilon),
                                   dual.C)
    certificate = model_certificate(dual.y, beta, Kbeta, b, dual.C, dual.epsilon,
                                    float(np.max(np.diagonal(dual.K), initial=0.0)))
    solution = Solution.of_qp(dual.qp, (x, y_eq, None, z_box), record, extra_residuals=certificate)
    with rejected_coefficients(beta):
        require_certificates(solution, dual.qp, check_tol)
        require_model_certificate(solution.residuals, check_tol, record.backend)
    return solution


class DualFit(NamedTuple):
    """What every certified dual fit returns (:func:`solve_dual`,
    ``solve_dual_ipm``, the ``auto`` paths)."""

    #: all n coefficients, alpha* - alpha (as returned: see returned_coefficients)
    beta: NDArray[np.float64]
    intercept: float  #: the bias b from the KKT conditions
    #: the QP that was solved, in the units of the data (None: never formed)
    problem: QuadraticProgram | None
    solution: Solution  #: its certificate-checked solution, at the returned (beta, b)
    polished: bool  #: whether polish() or the crossover replaced the solver's coefficients


def certified_dual_fit(dual: DualProblem, beta: NDArray[np.float64], record: SolverRecord,
                       check_tol: float, polished: bool) -> DualFit:
    r"""Round β to the coefficients a model keeps
    (:func:`~svrqp.formulations.epsilon_svr.returned_coefficients`), read b off the KKT
    conditions and certify both on ``dual.qp`` (:func:`_certified_solution`)."""
    beta = returned_coefficients(beta, dual.C, exact=polished)
    b = intercept_from_kkt(dual.K, dual.y, beta, dual.C, dual.epsilon)
    return DualFit(beta, b, dual.qp, _certified_solution(dual, beta, b, record, check_tol),
                   polished)


def solve_dual(K: NDArray[np.float64], y: NDArray[np.float64], C: float, epsilon: float,
               backend: str = "clarabel", settings: DualSettings = DualSettings(), *,
               initvals: NDArray[np.float64] | None = None) -> DualFit:
    r"""Build a dual QP, solve it in well-scaled units,
    polish it, and read off :math:`\beta` and ``b``.

    The one sequence every dual fit goes through (the estimators and the tuning loops). The
    backend solves the QP of :class:`DualScaling` (its settings record the scaling under
    ``"scaling"``); the coefficients are mapped back, rounded to what the model keeps, and
    certified on the QP in the units of the data (``problem``, also returned): its relative
    residuals and :func:`~svrqp.formulations.epsilon_svr_certificate.model_certificate` must be
    at most ``settings.check_tol`` (default 100·tol), otherwise
    :class:`~svrqp.exceptions.SolverError` names the backend. ``initvals`` is a solution of that
    QP (e.g. a previous ``DualFit.solution.x``).
    """
    check_parameters(y, C, epsilon)
    tol, formulation = settings.tol, settings.formulation
    check_tol = check_limit(tol, settings.check_tol)
    dual = DualProblem.of(formulation, K, y, C, epsilon)
    m, a, u = scaling = DualScaling.of(y, dual.C)
    K_scaled, y_scaled, C_scaled, epsilon_scaled = ((K if u == a else (u / a) * K), (y - m) / a,
                                                    dual.C / u, dual.epsilon / a)
    scaled = build(formulation, y_scaled, C_scaled, epsilon_scaled, K=K_scaled)
    record = qp_backends.solve_qp(scaled, backend, tol=tol, check_tol=check_tol,
                                  initvals=None if initvals is None
                                  else np.asarray(initvals, dtype=float) / u)
    record.settings["scaling"] = scaling._asdict()
    beta_scaled = beta_from_solution(formulation, y.shape[0], record.x)
    polished = polish(K_scaled, y_scaled, beta_scaled, C_scaled, epsilon_scaled)
    if polished is None:
        # The exact crossover of svrqp.solvers.dual_ipm: polish guesses the active sets once, the
        # crossover corrects them (coefficients a few 1e-6·C inside a bound, for instance).
        exact = crossover(DenseColumns(K_scaled), y_scaled, C_scaled, epsilon_scaled,
                          beta_scaled,
                          kernel_scale=float(np.max(np.diagonal(K_scaled), initial=0.0)))
        polished = exact.beta if exact.exact else None
    beta = u * (beta_scaled if polished is None else polished)
    return certified_dual_fit(dual, beta, record.record, check_tol, polished is not None)
