"""QuadraticProgram and LinearSystem: validation, objective, certificates, LaTeX."""

import numpy as np
import pytest
import scipy.sparse as sp

from svrqp import ProblemError
from svrqp.problems import LinearSystem, QuadraticProgram
from support.problems import box_qp


def test_objective_and_exact_certificates_at_the_known_optimum():
    qp = box_qp()
    x, y = np.array([0.5, 0.5]), np.array([0.5])
    assert qp.objective(x) == pytest.approx(0.25 - 1.0)
    r = qp.kkt_residuals(x, y=y, z_box=np.zeros(2))
    assert r["primal"] == pytest.approx(0.0, abs=1e-15)
    assert r["dual"] == pytest.approx(0.0, abs=1e-15)
    assert r["gap"] == pytest.approx(0.0, abs=1e-15)


def test_certificates_see_a_wrong_point():
    r = box_qp().kkt_residuals(np.array([0.9, 0.3]), y=np.array([0.5]))
    assert r["primal"] == pytest.approx(0.2)  # both the equality and the upper bound are off
    assert r["dual"] > 0.1


def test_active_bound_multiplier_sign_convention():
    """min ½x² − 2x s.t. x ≤ 1: x = 1 and z_box = +1 (positive on an active upper bound)."""
    qp = QuadraticProgram(P=np.eye(1), q=np.array([-2.0]), ub=np.ones(1))
    r = qp.kkt_residuals(np.ones(1), z_box=np.ones(1))
    assert r["dual"] == 0.0 and r["gap"] == 0.0


@pytest.mark.parametrize("kwargs, word", [
    ({"P": np.array([[1.0, 2.0], [2.0, 1.0]])}, "positive semidefinite"),
    ({"P": np.array([[1.0, 0.5], [0.0, 1.0]])}, "symmetric"),
    ({"P": np.eye(2), "q": np.ones(3)}, "q"),
    ({"P": np.eye(2), "q": np.array([np.nan, 0.0])}, "q"),
    ({"P": np.eye(2), "lb": np.ones(2), "ub": np.zeros(2)}, "lb"),
    ({"P": np.eye(2), "A": np.ones((1, 3)), "b": np.ones(1)}, "A"),
    ({"P": np.eye(2), "A": np.ones((1, 2))}, "together"),
    ({"P": np.array([["a", "b"], ["c", "d"]], dtype=object)}, "numeric"),
    ({"P": np.array([[np.inf, 0.0], [0.0, 1.0]])}, "NaN or infinite"),
])
def test_invalid_problems_are_rejected(kwargs, word):
    kwargs = {"q": np.zeros(2), **kwargs}
    with pytest.raises(ProblemError, match=word):
        QuadraticProgram(**kwargs)


def test_sparse_diagonal_p_is_accepted_and_negative_diagonal_rejected():
    QuadraticProgram(P=sp.diags([1.0, 0.0]), q=np.zeros(2))
    with pytest.raises(ProblemError, match="PSD"):
        QuadraticProgram(P=sp.diags([1.0, -1.0]), q=np.zeros(2))


def test_latex_states_the_problem():
    text = box_qp().to_latex()
    assert r"\tfrac12 x^\top P x + q^\top x" in text and "A x = b" in text and r"lb \le x \le ub" in text


def test_linear_system_residual_and_validation():
    system = LinearSystem(M=np.array([[2.0, 0.0], [0.0, 4.0]]), rhs=np.array([2.0, 4.0]))
    assert system.residual(np.ones(2))["residual"] == 0.0
    assert "M x" in system.to_latex()
    with pytest.raises(ProblemError, match="square"):
        LinearSystem(M=np.ones((2, 3)), rhs=np.ones(2))
