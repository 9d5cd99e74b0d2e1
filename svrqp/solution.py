"""The outcome of every solve: a certificate-checked :class:`Solution`.

Every solver path (the qpsolvers backends and cvxpy, the LU of a linear system, the exact
ε-SVR paths) returns one; :func:`require_certificates` is the one check that a QP solution
meets its relative primal residual, dual residual and duality gap.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from svrqp.exceptions import SolverError
from svrqp.problems import QuadraticProgram

#: One vocabulary of statuses; every backend's outcome is mapped into it.
STATUSES = ("optimal", "infeasible", "max_iter", "time_limit", "failed")


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
    backend, backend_version, settings
        Who solved it, and every setting actually passed (defaults made explicit).
    build_time, solve_time
        Seconds spent converting matrices for the backend, and inside the backend.
    iterations
        Iteration count when the backend reports one.
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64] | None
    z: NDArray[np.float64] | None
    z_box: NDArray[np.float64] | None
    objective: float
    status: str
    residuals: dict[str, float]
    backend: str
    backend_version: str
    settings: dict[str, Any] = field(default_factory=dict)
    build_time: float = 0.0
    solve_time: float = 0.0
    iterations: int | None = None

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



def require_certificates(solution: Solution, problem: QuadraticProgram, check_tol: float) -> None:
    """Raise :class:`SolverError` naming the backend when a relative primal residual, dual
    residual or duality gap of ``solution`` exceeds ``check_tol`` (NaN included)."""
    failed = [key for key in ("primal_rel", "dual_rel", "gap_rel") if not solution.residuals[key] <= check_tol]
    if failed:
        worst = failed[0]
        raise SolverError(f"backend {solution.backend!r} did not solve {problem.name!r}: its {worst[:-4]} "
                          f"certificate is {solution.residuals[worst]:.2e} (relative) > {check_tol:.1e}",
                          solution.backend, "inaccurate")

