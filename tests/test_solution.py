"""Solution: the one constructor of every solve path, evaluated on the problem it solves."""

from __future__ import annotations

import numpy as np
from support.problems import box_qp

from svrqp.problems import LinearSystem
from svrqp.solution import Solution, SolverRecord


def test_of_qp_evaluates_objective_and_residuals_on_the_problem():
    problem = box_qp()  # optimum (0.5, 0.5) with y = 0.5, no bound active
    record = SolverRecord("by-hand", "1.0", {"tol": 1e-8}, build_time=1.0, solve_time=2.0, iterations=3)
    solution = Solution.of_qp(problem, (np.array([0.5, 0.5]), np.array([0.5]), None, np.zeros(2)), record,
                              extra_residuals={"kkt_rel": 0.25})
    assert solution.objective == -0.75  # ½(0.25 + 0.25) − 1, by hand
    assert max(solution.primal_residual, solution.dual_residual, solution.duality_gap) <= 1e-15
    assert solution.residuals["kkt_rel"] == 0.25 and solution.status == "optimal"
    assert solution.record == record


def test_of_qp_sees_a_wrong_multiplier():
    problem = box_qp()
    solution = Solution.of_qp(problem, (np.array([0.5, 0.5]), np.array([0.0]), None, np.zeros(2)),
                              SolverRecord("by-hand", "1.0"))
    assert solution.dual_residual == 0.5  # P x + q + Aᵀy = −0.5 in each row
    assert not solution.is_optimal(1e-6)


def test_of_linear_system_keeps_the_residual_as_its_certificate():
    system = LinearSystem(M=np.array([[2.0, 0.0], [0.0, 4.0]]), rhs=np.array([2.0, 2.0]))
    x = np.array([1.0, 0.5])
    solution = Solution.of_linear_system(x, system.residual(x), SolverRecord("lu", "1"))
    assert solution.residuals == {"primal": 0.0, "primal_rel": 0.0} and solution.objective == 0.0
