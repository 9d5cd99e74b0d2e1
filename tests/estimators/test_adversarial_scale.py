"""Second hostile campaign (issue #39), findings 14 and 15: ε-SVR problems whose scale is hostile.

Finding 14: targets of 1e-12 with a tube of 1e-12 or 1e-14 (a dual box 1e13 wide once the targets
are scaled to 1), constant targets, a tube below the resolution of y. Finding 15: a linear kernel
on inputs of 1e3 to 6e7 with C = 10 (a nearly hard margin). Each answer is compared with an
independent reference (cvxpy and Clarabel on a formulation in well-scaled units), or is a
documented error that names the scale and what to do. No test measures time: a case that used to
hang asserts what it ends in.
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from svrqp import EpsilonSVR
from svrqp.exceptions import ProblemError, SolverError
from svrqp.kernels import gram
from svrqp.solvers import qp_backends

#: DESIGN §3: predictions within 1e-5·std(y) of the reference.
PREDICTION_TOL = 1e-5


def tube_dual_reference(K: np.ndarray, y: np.ndarray, epsilon: float, C: float) -> np.ndarray:
    r"""Predictions at the training points of the ε-SVR dual with a Gram matrix K, solved by
    cvxpy and Clarabel in the units of std(y); an independent statement:
    :math:`\min \tfrac12\beta^\top K\beta - y^\top\beta + \varepsilon\lVert\beta\rVert_1`,
    :math:`\mathbf 1^\top\beta = 0`, :math:`|\beta| \le C`. A box wider than 1e6 in these
    units (1e13 for targets of 1e-12) is left out and checked inactive afterwards, so the answer
    is the boxed problem's too."""
    a, m = float(np.std(y)), float(np.mean(y))
    target, box = (y - m) / a, C / a
    beta = cp.Variable(y.size)
    objective = 0.5 * cp.quad_form(beta, cp.psd_wrap(K)) - target @ beta + epsilon / a * cp.norm1(beta)
    constraints = [cp.sum(beta) == 0] + ([cp.abs(beta) <= box] if box <= 1e6 else [])
    cp.Problem(cp.Minimize(objective), constraints).solve(
        solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
    value = beta.value
    assert box <= 1e6 or np.abs(value).max() < 1e-3 * box  # a box left out is far from active
    residual = target - K @ value
    free = (np.abs(value) > 1e-6 * np.abs(value).max()) & (np.abs(value) < box * (1 - 1e-6))
    b = float(np.median(residual[free] - epsilon / a * np.sign(value[free])))
    return a * (K @ value + b) + m


def tiny_targets(epsilon: float) -> tuple[np.ndarray, np.ndarray]:
    """#14's data: n = 10, y of order 1e-12."""
    X = np.random.default_rng(0).uniform(-1, 1, (10, 2))
    return X, 1e-12 * np.sin(3 * X[:, 0])


TINY_TARGET_SOLVERS = ["auto", "smo_crossover", "dual_ipm", "proxqp", "osqp", "highs"]


@pytest.mark.parametrize("solver", TINY_TARGET_SOLVERS)
def test_tiny_targets_and_tube_give_the_reference_answer(solver):
    """y ~ 1e-12 with ε = 1e-14: the exact paths worked in the units of y with absolute tolerances
    and returned a model 1.5·std(y) off the optimum (auto raised SolverError). Now every path
    (HiGHS by its fallback) gives the reference's predictions."""
    X, y = tiny_targets(1e-14)
    model = EpsilonSVR(C=10, epsilon=1e-14, gamma=1, solver=solver).fit(X, y)
    expected = tube_dual_reference(gram(X, gamma=1.0), y, 1e-14, 10.0)
    np.testing.assert_allclose(model.predict(X), expected, rtol=0, atol=PREDICTION_TOL * y.std())


@pytest.mark.parametrize("solver", TINY_TARGET_SOLVERS)
def test_tiny_targets_inside_a_tube_as_wide_give_no_support_vector(solver):
    """#14 as filed (ε = 1e-12, y within ±1e-12 of one value): HiGHS ran for 90 s. Every y fits
    in the tube around one b, so β = 0 is optimal: no support vector, every point in the tube."""
    X, y = tiny_targets(1e-12)
    assert np.ptp(y) < 2e-12  # the premise: one tube holds every point
    model = EpsilonSVR(C=10, epsilon=1e-12, gamma=1, solver=solver).fit(X, y)
    assert model.support_.size == 0
    assert np.max(np.abs(y - model.predict(X))) <= 1e-12 * (1 + 1e-9)


def test_tiny_targets_on_highs_end_at_its_iteration_limit(monkeypatch):
    """HiGHS cycled through a million iterations on #14's 10-point dual; with its time limit out of
    the way, its iteration limit alone ends the call in a SolverError naming it."""
    monkeypatch.setattr(qp_backends, "TIME_LIMIT_S", 1e9)
    X, y = tiny_targets(1e-12)
    with pytest.raises(SolverError, match="'highs'") as error:
        EpsilonSVR(C=10, epsilon=1e-12, gamma=1, solver="highs", fallback=False).fit(X, y)
    assert error.value.backend == "highs"


@pytest.mark.parametrize("solver", ["auto", "dual_ipm", "highs", "proxqp", "clarabel", "osqp"])
@pytest.mark.parametrize("level", [0.0, 3.0, 1e-12])
def test_constant_targets_give_the_all_zero_dual(solver, level):
    """A constant y is inside any tube around b = y: no support vector, b = y."""
    X, _ = tiny_targets(1e-12)
    model = EpsilonSVR(C=10, epsilon=1e-12, gamma=1, solver=solver, fallback=False).fit(
        X, np.full(10, level))
    assert model.support_.size == 0
    assert model.intercept_[0] == pytest.approx(level, rel=1e-12, abs=1e-300)


def test_tube_below_the_resolution_of_y_acts_as_no_tube():
    """ε = 1e-14 on y ≈ 1000 is below the spacing of doubles there (1.1e-13): the fit is the
    ε = 0 one, to the rounding of y."""
    X, y = tiny_targets(1e-12)
    y = 1000.0 + 1e12 * y
    model = EpsilonSVR(C=10, epsilon=1e-14, gamma=1).fit(X, y)
    expected = tube_dual_reference(gram(X, gamma=1.0), y, 0.0, 10.0)
    np.testing.assert_allclose(model.predict(X), expected, rtol=0, atol=PREDICTION_TOL * y.std())


def linear_problem() -> tuple[np.ndarray, np.ndarray]:
    """#15's data: 80 standard normal inputs in 3 columns, a linear target with noise as wide as
    the tube (so about a quarter of the points sit at ±C)."""
    rng = np.random.default_rng(0)
    Z = rng.standard_normal((80, 3))
    return Z, Z @ np.array([1.0, -2.0, 0.5]) + 0.1 * rng.standard_normal(80)


def linear_reference(Z: np.ndarray, y: np.ndarray, scale: float, C: float,
                     epsilon: float) -> np.ndarray:
    r"""Predictions of the ε-SVR with a linear kernel on inputs ``scale``·Z, from its primal on the
    unit inputs Z (cvxpy and Clarabel): with :math:`w = v/s` the objective
    :math:`\tfrac12\lVert w\rVert^2 + C\sum\xi` is :math:`C\,(\tfrac12\lVert v\rVert^2/(C s^2) +
    \sum\xi)`, every number of order 1."""
    v, b = cp.Variable(Z.shape[1]), cp.Variable()
    xi = cp.Variable(y.size, nonneg=True)
    residual = y - Z @ v - b
    problem = cp.Problem(cp.Minimize(0.5 * cp.sum_squares(v) / (C * scale**2) + cp.sum(xi)),
                         [residual <= epsilon + xi, -residual <= epsilon + xi])
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    return Z @ v.value + b.value


@pytest.mark.parametrize("scale", [1e2, 1e3])
def test_linear_kernel_on_large_inputs_gives_the_reference_answer(scale):
    """Inputs of 1e3: every path failed (the crossover's slack on the tube conditions was below
    the rounding of Kβ itself). Now the default fit gives the reference's predictions."""
    Z, y = linear_problem()
    model = EpsilonSVR(C=10, kernel="linear").fit(Z * scale, y)
    expected = linear_reference(Z, y, scale, 10.0, 0.1)
    np.testing.assert_allclose(model.predict(Z * scale), expected, rtol=0,
                               atol=PREDICTION_TOL * y.std())


@pytest.mark.parametrize("scale", [1e5, 1e7, 6e7])
def test_linear_kernel_beyond_double_precision_is_refused_naming_the_scale(scale):
    """Inputs of 1e5 and more with C = 10: about 20 coefficients at ±C times kernel values of
    1e11–1e16 must cancel to predictions of order 1, beyond double precision. It ran for
    minutes, then ended in a SolverError; now a ProblemError names C, max K(x, x) and the input
    size and says what to do."""
    Z, y = linear_problem()
    with pytest.raises(ProblemError, match=r"max K\(x, x\) = .*inputs of size .*standardise X"):
        EpsilonSVR(C=10, kernel="linear").fit(Z * scale, y)


def test_linear_primal_beyond_double_precision_is_refused_not_returned():
    """The primal at inputs of 1e5 returned a model whose predictions are off by 1e-4·std(y)
    (its certificate's rounding allowance covers it); now it is refused like the dual."""
    Z, y = linear_problem()
    with pytest.raises(ProblemError, match="cannot be represented in double precision"):
        EpsilonSVR(C=10, kernel="linear", formulation="primal").fit(Z * 1e5, y)


def test_linear_kernel_on_inputs_of_6e7_with_no_answer_says_what_to_do():
    """#15 as filed (40 points): no solver returns any answer at all; the SolverError says how far
    a model at the bound would round and what to do."""
    rng = np.random.default_rng(1)
    Z = rng.normal(size=(40, 3))
    y = Z @ [1.0, 2.0, 3.0] + 0.1 * rng.normal(size=40)
    with pytest.raises((SolverError, ProblemError), match=r"max K\(x, x\).*standardise X"):
        EpsilonSVR(C=10, kernel="linear").fit(Z * 6e7, y)
