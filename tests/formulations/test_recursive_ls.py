"""Recursive least squares (S3 eqs. 13–19) and the batch merge (S3 eqs. 20–24).

References are independent of the code under test: ``numpy.linalg.lstsq`` on the full
(or weighted) data.
"""

from __future__ import annotations

import numpy as np
import pytest

from svrqp.exceptions import ProblemError, SingularSystemError
from svrqp.formulations.least_squares import IllConditionedWarning
from svrqp.formulations.recursive_ls import (
    batch_state,
    initial_prefix,
    merge,
    transform_regressors,
    update,
    update_batch,
)

#: S3 eq. (25): Δr = C0 + Cc θc + Cn θn + Cs θs + Cb θb, radial error in μm.
S3_COEF = np.array([-30.0, 0.5, 1.2, 0.8, 0.3])


@pytest.fixture
def s3_turning_centre() -> tuple[np.ndarray, np.ndarray]:
    """120 workpieces on S3's turning centre: coolant, X-nut, spindle and bed temperatures
    warming up over a shift; regressors (1, θc, θn, θs, θb); radial error with 1 μm noise."""
    rng = np.random.default_rng(2003)
    n = 120
    shift = np.linspace(0.0, 1.0, n)
    theta = np.column_stack([
        20.0 + 3.0 * shift + 0.3 * rng.standard_normal(n),  # coolant
        22.0 + 8.0 * (1.0 - np.exp(-3.0 * shift)) + 0.2 * rng.standard_normal(n),  # X-axis nut
        25.0 + 12.0 * (1.0 - np.exp(-5.0 * shift)) + 0.5 * rng.standard_normal(n),  # spindle
        20.0 + 2.0 * shift + 0.2 * rng.standard_normal(n),  # bed
    ])
    Z = np.column_stack([np.ones(n), theta])
    return Z, Z @ S3_COEF + rng.standard_normal(n)


def _lstsq(Z: np.ndarray, y: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    root = np.ones(len(y)) if weights is None else np.sqrt(weights)
    return np.linalg.lstsq(Z * root[:, None], y * root, rcond=None)[0]


def test_rls_after_all_samples_equals_batch_ls(s3_turning_centre):
    Z, y = s3_turning_centre
    p = Z.shape[1]
    state = update_batch(batch_state(Z[:p], y[:p]), Z[p:], y[p:])
    np.testing.assert_allclose(state.a, _lstsq(Z, y), rtol=1e-9)
    assert state.n_samples == len(y)


def test_sigma2_is_eq19_of_the_batch_residuals(s3_turning_centre):
    Z, y = s3_turning_centre
    p = Z.shape[1]
    state = update_batch(batch_state(Z[:p], y[:p]), Z[p:], y[p:])
    residual = y - Z @ _lstsq(Z, y)
    np.testing.assert_allclose(state.sigma2, residual @ residual / (len(y) - p), rtol=1e-9)


def test_merge_equals_refit_on_the_union(s3_turning_centre):
    Z, y = s3_turning_centre
    first, second, third = (batch_state(Z[s], y[s]) for s in (slice(0, 50), slice(50, 90),
                                                                slice(90, None)))
    merged = merge(merge(first, second), third)
    np.testing.assert_allclose(merged.a, _lstsq(Z, y), rtol=1e-9)
    residual = y - Z @ _lstsq(Z, y)
    np.testing.assert_allclose(merged.sse, residual @ residual, rtol=1e-9)
    assert merged.n_samples == len(y)


def test_merge_of_a_recursed_model_and_a_batch(s3_turning_centre):
    """On-line model (recursion over batch 1) merged with an off-line batch 2 model."""
    Z, y = s3_turning_centre
    online = update_batch(batch_state(Z[:5], y[:5]), Z[5:70], y[5:70])
    merged = merge(online, batch_state(Z[70:], y[70:]))
    np.testing.assert_allclose(merged.a, _lstsq(Z, y), rtol=1e-9)


def test_forgetting_recursion_equals_weighted_ls(s3_turning_centre):
    Z, y = s3_turning_centre
    lam = 0.97
    state = update_batch(batch_state(Z[:8], y[:8], forgetting=lam), Z[8:], y[8:])
    weights = lam ** np.arange(len(y) - 1, -1, -1, dtype=float)
    np.testing.assert_allclose(state.a, _lstsq(Z, y, weights), rtol=1e-9)
    np.testing.assert_allclose(state.weight, weights.sum(), rtol=1e-12)
    residual = y - Z @ state.a
    np.testing.assert_allclose(state.sse, weights @ residual**2, rtol=1e-9)


def test_forgetting_tracks_a_drifting_coefficient():
    """The thermal gain drifts linearly from 1.0 to 3.0 μm/°C over 400 workpieces whose
    temperatures scatter over 20–30 °C. Exponential forgetting makes the estimate follow the
    gain with a lag of about λ/(1−λ) samples (19 for λ = 0.95, i.e. 0.095 μm/°C here); λ = 1
    averages the whole past and falls far behind."""
    rng = np.random.default_rng(19)
    n = 400
    theta_C = rng.uniform(20.0, 30.0, n)
    gain = np.linspace(1.0, 3.0, n)
    y_um = 4.0 + gain * theta_C + 0.2 * rng.standard_normal(n)
    Z = np.column_stack([np.ones(n), theta_C])

    def gain_error_second_half(lam: float) -> float:
        state = batch_state(Z[:2], y_um[:2], forgetting=lam)
        estimates = []
        for k in range(2, n):
            state = update(state, Z[k], y_um[k])
            estimates.append(state.a[1])
        return float(np.mean(np.abs(np.array(estimates) - gain[2:])[n // 2:]))

    expected_lag = 0.95 / 0.05 * (gain[1] - gain[0])
    assert gain_error_second_half(0.95) < 1.5 * expected_lag
    assert gain_error_second_half(1.0) > 5.0 * expected_lag


def test_bad_forgetting_factor(s3_turning_centre):
    Z, y = s3_turning_centre
    for lam in (0.0, 1.5, -0.2):
        with pytest.raises(ProblemError, match="forgetting factor must lie in"):
            batch_state(Z, y, forgetting=lam)


def test_constant_sensor_is_singular(s3_turning_centre):
    Z, y = s3_turning_centre
    Z = Z.copy()
    Z[:, 2] = 24.0  # a sensor stuck at 24 °C is collinear with the constant regressor
    with pytest.raises(SingularSystemError, match=r"rank deficient.*'const'.*'theta_n'"):
        batch_state(Z, y, column_names=["const", "theta_c", "theta_n", "theta_s", "theta_b"])


def test_fewer_samples_than_parameters(s3_turning_centre):
    Z, y = s3_turning_centre
    with pytest.raises(ProblemError, match="fewer samples"):
        batch_state(Z[:3], y[:3])


def test_nan_and_shape_errors(s3_turning_centre):
    Z, y = s3_turning_centre
    state = batch_state(Z, y)
    with pytest.raises(ProblemError, match="non-finite"):
        update(state, np.array([1.0, np.nan, 2.0, 3.0, 4.0]), 1.0)
    with pytest.raises(ProblemError, match="y is not finite"):
        update(state, Z[0], np.nan)
    with pytest.raises(ProblemError, match="x has 3 regressors, the model has 5"):
        update(state, Z[0, :3], 1.0)
    with pytest.raises(ProblemError, match="cannot merge models with 5 and 3"):
        merge(state, batch_state(Z[:, :3], y))
    with pytest.raises(ProblemError, match="forgetting factors"):
        merge(state, batch_state(Z, y, forgetting=0.9))


def test_recursion_starts_only_once_the_coefficients_are_well_determined():
    """A sensor that hardly moves for the first ten samples (1e-6 °C steps), then warms.
    Two samples already make (1, θ) full rank, but starting there gave the covariance-form
    recursion a P₀ so inaccurate that it ended 3e-3 off; initial_prefix waits for sample 11. The
    square-root recursion (issue #39) carries no P₀ error along: both starts end at round-off."""
    rng = np.random.default_rng(5)
    n = 200
    theta_C = np.r_[25.0 + 1e-6 * np.arange(10), 25.0 + 0.05 * np.arange(1, n - 9)]
    Z = np.column_stack([np.ones(n), theta_C])
    y = 3.0 + 2.0 * theta_C + 0.1 * rng.standard_normal(n)
    start = initial_prefix(Z)
    assert start == 11
    state = update_batch(batch_state(Z[:start], y[:start]), Z[start:], y[start:])
    np.testing.assert_allclose(state.a, _lstsq(Z, y), rtol=1e-9)
    with pytest.warns(IllConditionedWarning):
        naive = update_batch(batch_state(Z[:2], y[:2]), Z[2:], y[2:])
    np.testing.assert_allclose(naive.a, _lstsq(Z, y), rtol=1e-9)
    assert initial_prefix(Z[:10]) is None


def test_transformed_regressors_describe_the_same_model(s3_turning_centre):
    """Temperatures re-referenced to 20 °C: θ̃ = θ − 20, i.e. x̃ = T x with T[1:, 0] = −20."""
    Z, y = s3_turning_centre
    T = np.eye(5)
    T[1:, 0] = -20.0
    state = batch_state(Z, y)
    moved = transform_regressors(state, T)
    Z_moved = Z @ T.T
    np.testing.assert_allclose(Z_moved @ moved.a, Z @ state.a, rtol=1e-12)
    np.testing.assert_allclose(moved.a, _lstsq(Z_moved, y), rtol=1e-9)
    np.testing.assert_allclose(moved.P, np.linalg.inv(Z_moved.T @ Z_moved), rtol=1e-8)
    with pytest.raises(SingularSystemError, match="singular"):
        transform_regressors(state, np.zeros((5, 5)))
