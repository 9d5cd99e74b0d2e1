"""Transforms of candidate columns: rate, first-order lag, time-constant grid (svrqp.gap.data.transforms)."""

import numpy as np
import pytest
from scipy.signal import lfilter

from svrqp.exceptions import ProblemError
from svrqp.gap.data.transforms import (
    MIN_STRETCH,
    _even_stretches,
    filter_coefficients,
    group_slices,
    lag,
    lowpass,
    lowpass_columns,
    negligible,
    rate,
    standardised,
    tau_grid,
)

# Two runs of a sine, the second on an uneven time grid: a closed-form derivative to compare to.
T_RUN1 = np.linspace(0.0, 10.0, 201)
T_RUN2 = np.sort(np.r_[0.0, np.random.default_rng(0).uniform(0.0, 10.0, 199), 10.0])
T = np.r_[T_RUN1, T_RUN2]
GROUPS = np.r_[np.zeros(201, int), np.ones(201, int)]


def test_group_slices_are_the_contiguous_runs():
    assert group_slices(GROUPS) == [slice(0, 201), slice(201, 402)]


def test_group_slices_reject_interleaved_groups():
    with pytest.raises(ProblemError, match="contiguous"):
        group_slices(np.array([0, 1, 0]))


def test_rate_matches_the_analytic_derivative_within_each_group():
    x = np.sin(T)
    # second-order central differences: error O(h^2) inside, O(h) at the two ends of a group
    inner = np.ones_like(T, bool)
    inner[[0, 200, 201, 401]] = False
    np.testing.assert_allclose(rate(x, T, GROUPS)[inner], np.cos(T)[inner], atol=5e-3)


def test_rate_restarts_per_group():
    # a jump between groups must not leak into either group's rate
    x = np.r_[np.ones(201), 5 * np.ones(201)]
    np.testing.assert_allclose(rate(x, T, GROUPS), 0.0, atol=1e-9)


def test_lowpass_step_response_is_one_minus_exp():
    t = np.arange(0.0, 100.0)
    x = np.r_[0.0, np.ones(99)]  # step held after t=0, filter starts in equilibrium at 0
    y = lowpass(x, t, np.zeros(100, int), np.array([10.0]))[:, 0]
    # zero-order hold: y_k = 1 - exp(-k dt / tau) for k >= 1
    np.testing.assert_allclose(y[1:], 1 - np.exp(-np.arange(1, 100) / 10.0), rtol=0, atol=1e-12)


def test_lowpass_equals_scipy_lfilter_on_a_uniform_grid():
    rng = np.random.default_rng(1)
    x = rng.normal(size=300).cumsum()
    t = np.arange(300.0)
    taus = np.array([3.0, 30.0])
    y = lowpass(x, t, np.zeros(300, int), taus)
    for j, tau in enumerate(taus):
        a = 1 - np.exp(-1.0 / tau)
        ref, _ = lfilter([a], [1, -(1 - a)], x, zi=[(1 - a) * x[0]])
        np.testing.assert_allclose(y[:, j], ref, rtol=1e-12, atol=1e-12)


def test_lowpass_columns_follow_the_recursion_on_mixed_sampling():
    # even stretches (filtered in compiled code), a jittered stretch (stepped) and a restart
    rng = np.random.default_rng(2)
    t = np.r_[np.arange(0.0, 40.0, 0.1), 40.0 + np.cumsum(rng.uniform(0.05, 0.3, MIN_STRETCH)),
              np.arange(50.0, 80.0, 0.5), np.arange(0.0, 30.0, 0.5)]
    groups = np.r_[np.zeros(t.size - 60, int), np.ones(60, int)]
    X = rng.normal(size=(t.size, 3)).cumsum(axis=0)
    alpha = filter_coefficients(t, groups, np.array([0.7, 6.0]))
    expected = np.empty((t.size, 3, 2))
    state = np.zeros((3, 2))
    for k in range(t.size):  # the definition, one row at a time
        state = state + alpha[k] * (X[k][:, None] - state)
        expected[k] = state
    np.testing.assert_allclose(lowpass_columns(X, alpha), expected, rtol=1e-10, atol=1e-10)


def test_even_sampling_far_from_zero_is_one_stretch():
    # 1e5 + 0.1 k: the differences of the times carry rounding errors near 1e-10 relative
    t = 1e5 + 0.1 * np.arange(500)
    alpha = filter_coefficients(t, np.zeros(500, int), np.array([2.0, 20.0]))
    assert _even_stretches(alpha) == [(0, 1), (1, 500)]
    x = np.random.default_rng(3).normal(size=(500, 1)).cumsum(axis=0)
    expected, state = np.empty((500, 1, 2)), np.zeros((1, 2))
    for k in range(500):
        state = state + alpha[k] * (x[k][:, None] - state)
        expected[k] = state
    np.testing.assert_allclose(lowpass_columns(x, alpha), expected, rtol=1e-8, atol=1e-8)


def test_coefficients_where_the_order_restarts_raise_no_overflow(recwarn):
    # 1000 min runs whose time restarts at 0: the step into the second run is -999 min
    t = np.r_[np.arange(1000.0), np.arange(1000.0)]
    alpha = filter_coefficients(t, np.repeat([0, 1], 1000), np.array([0.5, 50.0]))
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]
    np.testing.assert_array_equal(alpha[[0, 1000]], 1.0)
    np.testing.assert_allclose(alpha[1], -np.expm1(-1.0 / np.array([0.5, 50.0])))


def test_lowpass_restarts_in_equilibrium_at_each_group():
    x = np.r_[np.zeros(201), 3 * np.ones(201)]
    y = lowpass(x, T, GROUPS, np.array([2.0]))[:, 0]
    assert y[201] == 3.0  # no memory of the first group


def test_lag_is_filtered_minus_signal():
    x = np.sin(T)
    taus = np.array([0.5, 4.0])
    np.testing.assert_allclose(lag(x, T, GROUPS, taus), lowpass(x, T, GROUPS, taus) - x[:, None])


def test_lag_of_slow_ramp_is_minus_tau_times_rate():
    # for x = c t the first-order lag settles at x_tau - x = -tau c
    t = np.arange(0.0, 500.0)
    ell = lag(0.2 * t, t, np.zeros(500, int), np.array([5.0]))[:, 0]
    assert ell[-1] == pytest.approx(-5.0 * 0.2, rel=0.12)  # ZOH adds about half a step


def test_tau_grid_spans_sampling_to_half_a_run():
    taus = tau_grid(T_RUN1, np.zeros(201, int), n_tau=5)
    assert taus[0] == pytest.approx(max(2 * 0.05, 10 / 100))
    assert taus[-1] == pytest.approx(5.0)
    assert np.all(np.diff(np.log(taus)) > 0)


def test_lowpass_rejects_non_positive_tau():
    with pytest.raises(ProblemError, match="positive"):
        lowpass(np.ones(3), np.arange(3.0), np.zeros(3, int), np.array([0.0]))


def test_negligible_spread_is_relative_to_the_values_magnitude():
    # a reading of 4500 stored with rounding noise is constant; a 1e-6 step on 1.0 is not
    steady = 4500.0 + np.array([0.0, 4e-10, -3e-10])
    step = np.array([1.0, 1.0 + 1e-6, 1.0])
    columns = np.column_stack([steady, step])
    assert negligible(np.ptp(columns, axis=0), columns).tolist() == [True, False]
    assert negligible(np.std(steady), steady, axis=None)
    assert not negligible(np.std(step), step, axis=None)


def test_standardised_columns_and_the_constant_ones():
    columns = np.column_stack([np.arange(5.0), np.full(5, 4500.0), 3.0 * np.arange(5.0) + 7.0])
    Z, varying = standardised(columns)
    assert varying.tolist() == [True, False, True]
    np.testing.assert_allclose(Z[:, 0], (np.arange(5.0) - 2.0) / np.std(np.arange(5.0)))
    np.testing.assert_array_equal(Z[:, 1], 0.0)
    np.testing.assert_allclose(Z[:, 2], Z[:, 0])
