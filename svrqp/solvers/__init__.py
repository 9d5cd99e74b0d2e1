"""The solvers: stated problems to certified :class:`~svrqp.solution.Solution` objects.

* :func:`solve_qp`: a :class:`~svrqp.problems.QuadraticProgram` by a qpsolvers backend or cvxpy
  (:mod:`svrqp.solvers.qp_backends`, which states the backends, their settings and the sign
  conventions of the multipliers);
* :func:`solve_linear_system`: a :class:`~svrqp.problems.LinearSystem` by LU
  (:mod:`svrqp.solvers.linear`);
* :mod:`svrqp.solvers.epsilon_svr`: the ε-SVR, the one entry point of the estimators and the
  tuning loops (it picks among :mod:`svrqp.solvers.auto`, :mod:`svrqp.solvers.dual_ipm`,
  :mod:`svrqp.solvers.dual_qp` and the backends, falls back and certifies).

Every returned solution has been certificate-checked.
"""

from __future__ import annotations

from svrqp.solution import Solution
from svrqp.solvers.linear import solve_linear_system
from svrqp.solvers.qp_backends import (
    BACKENDS,
    available_backends,
    backend_version,
    require_backend,
    solve_qp,
)

__all__ = ["BACKENDS", "Solution", "available_backends", "backend_version", "require_backend",
           "solve_linear_system", "solve_qp"]
