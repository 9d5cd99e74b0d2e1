"""Linear systems :math:`Mx = \\text{rhs}` (the LS-SVR KKT system, normal equations) by LU."""

from __future__ import annotations

import time
from importlib.metadata import version

import numpy as np
import scipy.linalg

from svrqp.exceptions import SolverError
from svrqp.problems import LinearSystem
from svrqp.solution import Solution, SolverRecord


def solve_linear_system(system: LinearSystem, *, check_tol: float = 1e-9) -> Solution:
    """Solve :math:`Mx = \\text{rhs}` by LU with partial pivoting (``scipy.linalg.solve``)."""
    start = time.perf_counter()
    try:
        x = scipy.linalg.solve(system.M, system.rhs)
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgWarning) as err:
        raise SolverError(f"LU failed on {system.name!r}: {err}", "lu", "failed") from err
    solve_time = time.perf_counter() - start
    residuals = system.residual(x)
    if residuals["residual_rel"] > check_tol:
        raise SolverError(f"LU residual {residuals['residual_rel']:.2e} > {check_tol:.1e} on "
                          f"{system.name!r}", "lu", "inaccurate")
    return Solution.of_linear_system(
        x, residuals, SolverRecord(
            "lu", f"scipy {version('scipy')}", {"check_tol": check_tol}, solve_time=solve_time
        ),
    )
