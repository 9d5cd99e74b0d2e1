"""Normal equations, polynomial least squares and the straightness reference line.

Cross-checks against independent references: scikit-learn ``LinearRegression``,
``numpy.polynomial.Polynomial.fit`` and ``numpy.polyfit``; plus the bad-input cases.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression

from svrqp.exceptions import ProblemError, SingularSystemError
from svrqp.formulations.least_squares import (
    IllConditionedWarning,
    fit_linear,
    fit_polynomial,
    reference_line,
    solve_normal_equations,
    straightness,
)

#: S0's MLR (eq. 5): S = 3.7674·T7 − 0.4237·T9 − 2.7669.
S0_COEF = np.array([3.7674, -0.4237])
S0_INTERCEPT = -2.7669


@pytest.fixture
def s0_thermal_batch() -> tuple[np.ndarray, np.ndarray]:
    """A summer batch like S0's x1: T7 heats from 30 °C towards 38 °C, ambient T9 drifts
    around 30 °C, 60 samples over 250 min; the error follows S0 eq. (5) plus 0.3 μm noise."""
    rng = np.random.default_rng(20130501)
    time_min = np.linspace(0.0, 250.0, 60)
    T7_C = 30.0 + 8.0 * (1.0 - np.exp(-time_min / 60.0))
    T9_C = 30.0 + 0.8 * np.sin(time_min / 40.0) + 0.05 * rng.standard_normal(60)
    X = np.column_stack([T7_C, T9_C])
    error_um = X @ S0_COEF + S0_INTERCEPT + 0.3 * rng.standard_normal(60)
    return X, error_um


@pytest.fixture
def s2_positioning_error() -> tuple[np.ndarray, np.ndarray]:
    """S2's X axis: 11 positions over 0–550 mm and a smooth positioning error δx (μm)."""
    x_mm = np.linspace(0.0, 550.0, 11)
    delta_x_um = 2.0 * np.sin(x_mm / 90.0) + 0.004 * x_mm + 0.1 * np.cos(x_mm / 17.0)
    return x_mm, delta_x_um


def test_fit_linear_equals_sklearn_linear_regression(s0_thermal_batch):
    X, y = s0_thermal_batch
    ours = fit_linear(X, y)
    reference = LinearRegression().fit(X, y)
    np.testing.assert_allclose(ours.coef, reference.coef_, rtol=1e-10)
    np.testing.assert_allclose(ours.intercept, reference.intercept_, rtol=1e-10)
    np.testing.assert_allclose(ours.predict(X), reference.predict(X), rtol=1e-12)


def test_fit_linear_without_intercept_equals_sklearn(s0_thermal_batch):
    X, y = s0_thermal_batch
    ours = fit_linear(X, y, fit_intercept=False)
    reference = LinearRegression(fit_intercept=False).fit(X, y)
    np.testing.assert_allclose(ours.coef, reference.coef_, rtol=1e-10)
    assert ours.intercept == 0.0


def test_fit_linear_recovers_s0_equation_without_noise(s0_thermal_batch):
    X, _ = s0_thermal_batch
    fit = fit_linear(X, X @ S0_COEF + S0_INTERCEPT)
    np.testing.assert_allclose(fit.coef, S0_COEF, rtol=1e-10)
    np.testing.assert_allclose(fit.intercept, S0_INTERCEPT, rtol=1e-10)


def test_polynomial_equals_numpy_polynomial_fit(s2_positioning_error):
    x_mm, y = s2_positioning_error
    ours = fit_polynomial(x_mm, y, 5)
    reference = np.polynomial.Polynomial.fit(x_mm, y, 5)
    np.testing.assert_allclose(ours.to_polynomial().coef, reference.coef, atol=1e-12)
    fine_mm = np.linspace(0.0, 550.0, 301)
    np.testing.assert_allclose(ours.predict(fine_mm), reference(fine_mm), atol=1e-12)
    np.testing.assert_allclose(ours.to_polynomial()(fine_mm), ours.predict(fine_mm), atol=1e-12)


def test_degree5_over_550mm_is_well_conditioned(s2_positioning_error):
    x_mm, y = s2_positioning_error
    with warnings.catch_warnings():
        warnings.simplefilter("error", IllConditionedWarning)
        fit = fit_polynomial(x_mm, y, 5)
    assert fit.condition_number < 100.0
    # Monomials on the same points, even with equilibrated columns, are far worse ...
    monomial = solve_normal_equations(np.vander(x_mm, 6), y)
    assert monomial.condition_number > 1e6
    # ... and past degree 7 they cross the warning threshold.
    with pytest.warns(IllConditionedWarning, match="ill conditioned"):
        solve_normal_equations(np.vander(x_mm, 10), y)


def test_reference_line_equals_numpy_polyfit(s2_positioning_error):
    x_mm, y = s2_positioning_error
    k, t = reference_line(x_mm, y)
    np.testing.assert_allclose([k, t], np.polyfit(x_mm, y, 1), rtol=1e-12)


def test_straightness_of_a_known_bump():
    """A tilted line plus a symmetric bump: the LS line removes the tilt, the range is exact."""
    x_mm = np.linspace(-75.0, 75.0, 151)
    bump_um = np.where(np.abs(x_mm) <= 25.0, 5.0, 0.0)
    bump_um = bump_um - bump_um.mean()  # keeps the bump orthogonal to 1 and x (it is even)
    y_um = 0.02 * x_mm + 3.0 + bump_um
    result = straightness(x_mm, y_um)
    np.testing.assert_allclose(result.slope, 0.02, rtol=1e-12)
    np.testing.assert_allclose(result.intercept, 3.0, rtol=1e-12)
    np.testing.assert_allclose(result.deviation, -bump_um, atol=1e-12)
    np.testing.assert_allclose(result.straightness, 5.0, rtol=1e-12)


def test_duplicated_temperature_column_is_named(s0_thermal_batch):
    X, y = s0_thermal_batch
    duplicated = np.column_stack([X, X[:, 0]])
    with pytest.raises(SingularSystemError, match=r"rank deficient.*'T7'.*'T7_copy'"):
        fit_linear(duplicated, y, column_names=["T7", "T9", "T7_copy"])


def test_constant_sensor_is_named(s0_thermal_batch):
    X, y = s0_thermal_batch
    with_constant = np.column_stack([X, np.full(len(y), 21.5)])
    with pytest.raises(SingularSystemError, match=r"constant column.*'T3'"):
        fit_linear(with_constant, y, column_names=["T7", "T9", "T3"])


def test_least_norm_only_when_asked(s0_thermal_batch):
    """T7 logged twice, once in units of 0.5 °C: the minimum-norm coefficients split the
    effect as a₀ : a₂ = 1 : 2 (minimum of a₀² + a₂² subject to a₀ + 2a₂ fixed)."""
    X, y = s0_thermal_batch
    duplicated = np.column_stack([X, 2.0 * X[:, 0]])
    fit = fit_linear(duplicated, y, rank_deficient="lstsq")
    reference = LinearRegression().fit(duplicated, y)  # scipy lstsq: the minimum-norm answer
    assert fit.rank == 2
    np.testing.assert_allclose(fit.coef, reference.coef_, rtol=1e-8)
    np.testing.assert_allclose(2.0 * fit.coef[0], fit.coef[2], rtol=1e-10)


def test_fewer_samples_than_parameters(s0_thermal_batch):
    X, y = s0_thermal_batch
    with pytest.raises(ProblemError, match=r"fewer samples than parameters: 2 sample\(s\) for 3 parameters"):
        fit_linear(X[:2], y[:2])
    with pytest.raises(ProblemError, match="at least 6 distinct"):
        fit_polynomial(np.arange(5.0), np.arange(5.0), 5)


def test_nan_is_rejected_with_its_position(s0_thermal_batch):
    X, y = s0_thermal_batch
    X = X.copy()
    X[7, 1] = np.nan
    with pytest.raises(ProblemError, match=r"X contains 1 non-finite.*\(7, 1\)"):
        fit_linear(X, y)
    with pytest.raises(ProblemError, match="y contains"):
        reference_line(np.arange(3.0), np.array([1.0, np.nan, 2.0]))


def test_reference_line_needs_distinct_positions():
    with pytest.raises(SingularSystemError, match="all x values are equal"):
        reference_line(np.full(4, 10.0), np.arange(4.0))
