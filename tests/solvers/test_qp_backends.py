"""The solver layer: options, backend discovery, certificate checks, statuses."""

import numpy as np
import pytest
from support.backends import require
from support.problems import box_qp

import svrqp.solvers.qp_backends as solve_module
from svrqp import BackendNotAvailableError, ProblemError, SolverError
from svrqp.problems import LinearSystem, QuadraticProgram
from svrqp.solvers import available_backends, solve_linear_system, solve_qp


def test_every_backend_solves_the_known_qp(backend):
    solution = solve_qp(box_qp(), backend)
    np.testing.assert_allclose(solution.x, [0.5, 0.5], atol=1e-6)
    assert solution.status == "optimal"
    assert solution.is_optimal(1e-6)
    assert solution.backend == backend and solution.backend_version
    assert solution.settings["tol"] == 1e-8  # the settings actually used are recorded


def test_unknown_option_is_rejected_with_the_valid_list():
    with pytest.raises(ProblemError, match=r"valid options: \[.*eps_abs"):
        solve_qp(box_qp(), "osqp", epsabs=1e-3)


def test_unknown_backend_is_named():
    with pytest.raises(ProblemError, match="known backends"):
        solve_qp(box_qp(), "gurobi-ish")


def test_missing_backend_names_the_extra(monkeypatch):
    monkeypatch.setattr(solve_module, "_installed", lambda backend: False)
    with pytest.raises(BackendNotAvailableError, match=r"svrqp\[solvers\]"):
        solve_qp(box_qp(), "piqp")


def test_a_solution_that_misses_the_check_raises_naming_the_backend():
    """An ADMM solve at a loose tolerance cannot pass a 1e-14 certificate check."""
    with pytest.raises(SolverError, match="'osqp'.*certificate"):
        solve_qp(box_qp(), "osqp", tol=1e-3, check_tol=1e-14, polishing=False)


def test_infeasible_problem_is_a_solver_error_with_a_status():
    qp = QuadraticProgram(P=np.eye(2), q=np.zeros(2), A=np.ones((1, 2)), b=np.array([5.0]),
                          lb=np.zeros(2), ub=np.ones(2))
    with pytest.raises(SolverError) as info:
        solve_qp(qp, "clarabel")
    assert info.value.backend == "clarabel" and info.value.status != "optimal"


def test_linear_systems_are_solved_by_lu():
    solution = solve_linear_system(LinearSystem(M=np.array([[4.0, 1.0], [1.0, 3.0]]), rhs=np.array([1.0, 2.0])))
    np.testing.assert_allclose(solution.x, np.linalg.solve([[4.0, 1.0], [1.0, 3.0]], [1.0, 2.0]))


def test_available_backends_lists_the_core_ones():
    assert {"clarabel", "osqp", "cvxpy"} <= set(available_backends())


def test_bad_tolerance():
    with pytest.raises(ProblemError, match="tol"):
        solve_qp(box_qp(), tol=-1.0)


@pytest.mark.parametrize("backend_name", ["piqp", "proxqp"])
def test_a_backend_setting_named_backend_goes_through_options(backend_name):
    """PIQP and ProxQP have a setting called ``backend``; ``options=`` carries it past solve's own parameter."""
    require(backend_name)
    for value in ("dense", "sparse"):
        solution = solve_qp(box_qp(), backend_name, options={"backend": value})
        np.testing.assert_allclose(solution.x, [0.5, 0.5], atol=1e-6)
        assert solution.backend == backend_name and solution.settings["backend"] == value
    with pytest.raises(SolverError, match=backend_name):  # the value reaches the backend, which refuses it
        solve_qp(box_qp(), backend_name, options={"backend": "no-such-linear-algebra"})


def test_a_setting_given_twice_is_rejected():
    with pytest.raises(ProblemError, match=r"\['eps_abs'\] given both"):
        solve_qp(box_qp(), "osqp", options={"eps_abs": 1e-6}, eps_abs=1e-7)
    assert solve_qp(box_qp(), "osqp", options={"eps_abs": 1e-9}).settings["eps_abs"] == 1e-9
