"""One entry point for every solver: ``solve(problem, backend=...) -> Solution``.

A :class:`~svrqp.problems.QuadraticProgram` goes to a qpsolvers backend or cvxpy
(:mod:`svrqp.solvers.qp_backends`, which states the backends, their settings and the sign
conventions of the multipliers); a :class:`~svrqp.problems.LinearSystem` to LU
(:mod:`svrqp.solvers.linear`). Every returned :class:`~svrqp.solution.Solution` has been
certificate-checked. svrqp's own exact ε-SVR paths are :mod:`svrqp.solvers.auto` and
:mod:`svrqp.solvers.dual_ipm`.
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
