"""The outcome of every solve: a certificate-checked :class:`Solution`.

Every solver path (the qpsolvers backends and cvxpy, the LU and Cholesky solves of a linear
system, the exact ε-SVR paths) returns one, built by :meth:`Solution.of_qp` or
:meth:`Solution.of_linear_system` from the point and a :class:`SolverRecord` (who solved it and
how); :func:`require_certificates` is the one check that a QP solution meets its relative primal
residual, dual residual and duality gap; :func:`rejected_coefficients` says how large an answer a
failed check rejected.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.exceptions import SolverError
from svrqp.problems import QuadraticProgram

#: Allowed slack between the requested ``tol`` and the relative certificates, because each
#: backend measures its own stopping criterion in its own (scaled) norm.
DEFAULT_CHECK_FACTOR = 100.0

#: One vocabulary of statuses; every backend's outcome is mapped into it.
STATUSES = ("optimal", "infeasible", "max_iter", "time_limit", "failed")

#: A QP point and its multipliers ``(x, y, z, z_box)`` (``None`` where undefined).
Point = tuple[NDArray[np.float64], NDArray[np.float64] | None, NDArray[np.float64] | None,
              NDArray[np.float64] | None]


@dataclass(frozen=True)
class SolverRecord:
    """Who solved a problem and how: the fields of :class:`Solution` that are not the point."""

    backend: str
    backend_version: str
    settings: dict[str, Any] = field(default_factory=dict)
    build_time: float = 0.0
    solve_time: float = 0.0
    iterations: int | None = None


@dataclass
class Solution:
    """A certificate-checked solution.

    Attributes
    ----------
    x, y, z, z_box
        Primal solution and multipliers (qpsolvers' sign convention; ``None`` where undefined).
    objective
        Objective value at ``x`` of the problem as stated (before any regularisation).
    status
        One of :data:`STATUSES`.
    primal_residual, dual_residual, duality_gap
        Absolute certificates; ``residuals`` holds them with their relative values.
    record
        Who solved it and how (:class:`SolverRecord`); its fields read as attributes of the
        solution too (``backend``, ``backend_version``, ``settings``, ``build_time``,
        ``solve_time``, ``iterations``).
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64] | None
    z: NDArray[np.float64] | None
    z_box: NDArray[np.float64] | None
    objective: float
    status: str
    residuals: dict[str, float]
    record: SolverRecord

    @property
    def backend(self) -> str:
        """Who solved it (``record.backend``)."""
        return self.record.backend

    @property
    def backend_version(self) -> str:
        """The solver's version (``record.backend_version``)."""
        return self.record.backend_version

    @property
    def settings(self) -> dict[str, Any]:
        """Every setting actually passed, defaults made explicit (``record.settings``)."""
        return self.record.settings

    @property
    def build_time(self) -> float:
        """Seconds spent converting matrices for the backend (``record.build_time``)."""
        return self.record.build_time

    @property
    def solve_time(self) -> float:
        """Seconds inside the backend (``record.solve_time``)."""
        return self.record.solve_time

    @property
    def iterations(self) -> int | None:
        """Iteration count when the backend reports one (``record.iterations``)."""
        return self.record.iterations

    @property
    def primal_residual(self) -> float:
        """Absolute primal residual (infinity norm)."""
        return self.residuals["primal"]

    @property
    def dual_residual(self) -> float:
        """Absolute dual residual (infinity norm of the Lagrangian's gradient)."""
        return self.residuals.get("dual", 0.0)

    @property
    def duality_gap(self) -> float:
        """Absolute duality gap."""
        return self.residuals.get("gap", 0.0)

    def is_optimal(self, eps: float) -> bool:
        """True when every relative certificate is at most ``eps``."""
        return all(value <= eps for key, value in self.residuals.items() if key.endswith("_rel"))

    @classmethod
    def of_qp(cls, problem: QuadraticProgram, point: Point, record: SolverRecord, *,
              extra_residuals: dict[str, float] | None = None) -> Solution:
        """The optimal solution ``point`` of ``problem``: its objective and KKT residuals evaluated
        on ``problem`` (:meth:`QuadraticProgram.kkt_residuals`), ``extra_residuals`` added.

        Not checked: :func:`require_certificates` is the caller's next step.
        """
        residuals = problem.kkt_residuals(*point)
        residuals.update(extra_residuals or {})
        x, y, z, z_box = point
        return cls(x=x, y=y, z=z, z_box=z_box, objective=problem.objective(x), status="optimal",
                   residuals=residuals, record=record)

    @classmethod
    def of_stated(cls, stated: Any, record: SolverRecord) -> Solution:
        """The solution at the point of ``stated``, whose residuals and objective on its QP were
        evaluated without forming it (a
        :class:`svrqp.formulations.epsilon_svr_residuals.StatedDual`: ``point``, ``residuals``,
        ``objective``).

        Not checked: :func:`require_certificates` is the caller's next step.
        """
        x, y, z, z_box = stated.point
        return cls(x=x, y=y, z=z, z_box=z_box, objective=stated.objective, status="optimal",
                   residuals=dict(stated.residuals), record=record)

    @classmethod
    def of_linear_system(cls, x: NDArray[np.float64], residual: dict[str, float],
                         record: SolverRecord) -> Solution:
        """The solution ``x`` of a linear system, certified by its residual
        (``{"residual", "residual_rel"}`` as
        :meth:`svrqp.problems.LinearSystem.residual` returns)."""
        return cls(x=x, y=None, z=None, z_box=None, objective=0.0, status="optimal",
                   residuals={"primal": residual["residual"],
                              "primal_rel": residual["residual_rel"]},
                   record=record)


def check_limit(tol: float, check_tol: float | None) -> float:
    """The largest relative certificate accepted: ``check_tol``,
    or ``DEFAULT_CHECK_FACTOR·tol`` when it is None."""
    return DEFAULT_CHECK_FACTOR * tol if check_tol is None else float(check_tol)


def require_certificates(solution: Solution, problem: QuadraticProgram | str,
                         check_tol: float) -> None:
    """Raise :class:`SolverError` naming the backend when a relative primal residual, dual
    residual or duality gap of ``solution`` exceeds ``check_tol`` (NaN included); ``problem`` is
    the QP solved, or its name."""
    failed = [key for key in ("primal_rel", "dual_rel",
                              "gap_rel") if not solution.residuals[key] <= check_tol]
    if failed:
        worst = failed[0]
        name = problem if isinstance(problem, str) else problem.name
        raise SolverError(f"backend {solution.backend!r} did not solve {name!r}: its "
                          f"{worst[:-4]} certificate is {solution.residuals[worst]:.2e} (relative) "
                          f"> {check_tol:.1e}", solution.backend, "inaccurate")


@contextmanager
def rejected_coefficients(beta: NDArray[np.float64]) -> Iterator[None]:
    r"""A :class:`~svrqp.exceptions.SolverError` raised inside says how large the rejected answer
    ``beta`` was (``coefficient_l1``, :math:`\sum_i|\beta_i|`)."""
    try:
        yield
    except SolverError as error:
        error.coefficient_l1 = float(np.abs(beta).sum())
        raise
