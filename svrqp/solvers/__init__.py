"""One entry point for every solver: ``solve(problem, backend=...) -> Solution``.

Quadratic programs go to any installed `qpsolvers <https://qpsolvers.github.io>`_ backend or to
cvxpy (the same QP stated in cvxpy's modelling language); linear systems go to a direct
factorisation. Every backend has one adapter entry in :data:`BACKENDS`: the extra that installs
it, the matrix format it prefers, how the common tolerance ``tol`` maps onto its own settings, and
the settings it accepts (anything else is rejected with the valid list — no unchecked ``**kwargs``).

Every returned :class:`Solution` has been certificate-checked: its relative primal residual,
dual residual and duality gap (see :meth:`QuadraticProgram.kkt_residuals`) are at most
``check_tol``; otherwise :class:`~svrqp.exceptions.SolverError` names the backend and its status.

Sign conventions follow qpsolvers: ``y`` multiplies :math:`Ax - b`, ``z \\ge 0`` multiplies
:math:`Gx - h`, and ``z_box`` is negative on active lower bounds, positive on active upper bounds.
"""

from __future__ import annotations

from typing import Any

from svrqp.exceptions import ProblemError
from svrqp.problems import LinearSystem, QuadraticProgram
from svrqp.solution import Solution
from svrqp.solvers.linear import solve_linear_system
from svrqp.solvers.qp_backends import (
    BACKENDS,
    available_backends,
    backend_version,
    require_backend,
    solve_qp,
)

__all__ = ["BACKENDS", "Solution", "available_backends", "backend_version", "require_backend", "solve",
           "solve_linear_system", "solve_qp"]



def solve(problem: QuadraticProgram | LinearSystem, backend: str = "clarabel", **kwargs: Any) -> Solution:
    """Solve a :class:`QuadraticProgram` (any QP backend) or a :class:`LinearSystem` (LU).

    See :func:`solve_qp` for the QP arguments (a backend setting named ``backend`` goes in
    ``options={"backend": ...}``).
    """
    if isinstance(problem, LinearSystem):
        return solve_linear_system(problem, **kwargs)
    if isinstance(problem, QuadraticProgram):
        return solve_qp(problem, backend, **kwargs)
    raise ProblemError(f"problem must be a QuadraticProgram or LinearSystem, got {type(problem).__name__}")
