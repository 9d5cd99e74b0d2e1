"""Compensation strategies (S4 eq. 8 windowed mean, S3 on-line loop) and residual metrics."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression

from svrqp.compensate import (
    compensate_recorded_run,
    improvement_percent,
    online_compensation,
    residual_metrics,
    windowed_mean_offsets,
)
from svrqp.exceptions import ProblemError
from svrqp.estimators import RecursiveLS


def _linear_deviation(x_mm: np.ndarray) -> np.ndarray:
    """ê(x) = 0.05 μm/mm · x − 2 μm: its window mean is the value at the window's midpoint."""
    return 0.05 * x_mm - 2.0


@pytest.fixture
def s4_straightness_run() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S4's test: X stroke 150 mm at 400 mm/min sampled at 15 Hz (≈ 0.44 mm per sample).
    The straightness deviation is a smooth +10 … −6 μm profile plus a 2 μm ripple of 7 mm
    period that a model of the trend does not see. Returns (x_mm, deviation_um, trend_um)."""
    x_mm = np.arange(0.0, 150.0, 400.0 / 60.0 / 15.0)
    trend_um = 2.0 + 8.0 * np.sin(2.0 * np.pi * x_mm / 150.0)
    deviation_um = trend_um + 1.0 * np.sin(2.0 * np.pi * x_mm / 7.0)
    return x_mm, deviation_um, trend_um


def test_metrics_of_a_known_vector():
    metrics = residual_metrics(np.array([1.0, -3.0, 5.0]))  # mean 1: RMS and std differ
    np.testing.assert_allclose(metrics.rms_um, np.sqrt(35.0 / 3.0), rtol=1e-15)
    np.testing.assert_allclose(metrics.std_um, np.sqrt(32.0 / 3.0), rtol=1e-15)
    assert metrics.max_abs_um == 5.0
    assert metrics.mean_abs_um == 3.0
    assert metrics.peak_to_peak_um == 8.0
    assert set(metrics.as_dict()) == {"rms_um", "std_um", "max_abs_um", "mean_abs_um",
                                      "peak_to_peak_um"}


def test_improvement_percent_of_s4():
    """S4: 16 μm straightness before, 7 μm after."""
    np.testing.assert_allclose(improvement_percent(16.0, 7.0), 56.25, rtol=1e-15)
    with pytest.raises(ProblemError, match="positive finite"):
        improvement_percent(0.0, 1.0)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_windowed_mean_of_a_linear_prediction_is_the_window_midpoint(direction):
    x_mm = 75.0 + direction * np.linspace(-60.0, 60.0, 25)
    offsets = windowed_mean_offsets(x_mm, _linear_deviation, samples_per_period=4,
                                    feed_forward_mm=10.0, dead_band_um=0.0)
    for start in range(0, 25, 4):
        x_0, x_T = x_mm[start], x_mm[min(start + 3, 24)]
        midpoint = 0.5 * (x_0 + x_T + direction * 10.0)
        np.testing.assert_allclose(offsets[start:start + 4], _linear_deviation(midpoint),
                                   rtol=1e-12, atol=1e-12)


def test_dead_band_suppresses_small_outputs():
    x_mm = np.linspace(0.0, 80.0, 41)
    offsets = windowed_mean_offsets(x_mm, _linear_deviation, samples_per_period=1,
                                    feed_forward_mm=0.0, dead_band_um=1.0)
    expected = np.where(np.abs(_linear_deviation(x_mm)) >= 1.0, _linear_deviation(x_mm), 0.0)
    np.testing.assert_allclose(offsets, expected, atol=1e-12)
    assert (offsets == 0.0).sum() == np.sum(np.abs(_linear_deviation(x_mm)) < 1.0) > 0


def test_compensating_the_trend_leaves_the_ripple(s4_straightness_run):
    x_mm, deviation_um, trend_um = s4_straightness_run

    def predict_trend(x: np.ndarray) -> np.ndarray:
        return np.interp(x, x_mm, trend_um)

    run = compensate_recorded_run(x_mm, deviation_um, predict_trend, samples_per_period=3,
                                  feed_forward_mm=0.5, dead_band_um=1.0)
    np.testing.assert_allclose(run.residual_um, deviation_um - run.offset_um, rtol=0, atol=0)
    # What is left is the 2 μm ripple plus dead-band and hold errors: below 4 μm peak to peak.
    assert run.before.peak_to_peak_um > 12.0
    assert run.after.peak_to_peak_um < 4.0
    assert run.improvement_percent > 60.0
    # A sign error in the compensation would double the deviation instead.
    wrong_sign = deviation_um + run.offset_um
    assert np.ptp(wrong_sign) > run.before.peak_to_peak_um


def test_bad_runs(s4_straightness_run):
    x_mm, deviation_um, _ = s4_straightness_run
    with pytest.raises(ProblemError, match="samples_per_period"):
        windowed_mean_offsets(x_mm, _linear_deviation, samples_per_period=0)
    with pytest.raises(ProblemError, match="move one way"):
        windowed_mean_offsets(np.r_[x_mm, 3.0], _linear_deviation, samples_per_period=2)
    with pytest.raises(ProblemError, match="predict_um must return"):
        windowed_mean_offsets(x_mm, lambda x: x[:-1], samples_per_period=2)
    with pytest.raises(ProblemError, match="differ in length"):
        compensate_recorded_run(x_mm, deviation_um[:-1], _linear_deviation, samples_per_period=2)
    with pytest.raises(ProblemError, match="x_mm contains 1 non-finite"):
        compensate_recorded_run(np.r_[x_mm[:-1], np.nan], deviation_um, _linear_deviation,
                                samples_per_period=2)


@pytest.fixture
def s3_workpieces() -> tuple[pd.DataFrame, pd.Series]:
    """150 workpieces on S3's turning centre; the spindle's thermal gain creeps up from 1.0 to
    1.6 μm/°C over the shift, which a static model fitted on the first 30 pieces misses."""
    rng = np.random.default_rng(25)
    n = 150
    shift = np.linspace(0.0, 1.0, n)
    X = pd.DataFrame({
        "theta_s_C": 25.0 + 12.0 * (1.0 - np.exp(-4.0 * shift)) + 0.5 * rng.standard_normal(n),
        "theta_b_C": 20.0 + 2.0 * shift + 0.2 * rng.standard_normal(n),
    })
    gain = 1.0 + 0.6 * shift
    y = pd.Series(-30.0 + gain * X.theta_s_C + 0.3 * X.theta_b_C + 0.5 * rng.standard_normal(n),
                  name="radial_error_um")
    return X, y


def test_online_predictions_are_batch_fits_on_the_past(s3_workpieces):
    """With λ = 1 the prediction for piece k is exactly the LS model of pieces 0 … k−1."""
    X, y = s3_workpieces
    initial = RecursiveLS().fit(X.iloc[:30], y.iloc[:30])
    online = online_compensation(initial, X.iloc[30:], y.iloc[30:])
    for k in (30, 31, 75, 149):
        past = LinearRegression().fit(X.iloc[:k], y.iloc[:k])
        np.testing.assert_allclose(online.run.offset_um[k - 30], past.predict(X.iloc[[k]])[0],
                                   rtol=1e-9)
    assert initial.n_samples_seen_ == 30  # the caller's model is not modified
    assert online.model.n_samples_seen_ == 150


def test_online_updating_beats_the_static_model(s3_workpieces):
    X, y = s3_workpieces
    static = RecursiveLS().fit(X.iloc[:30], y.iloc[:30])
    static_residual = residual_metrics(y.iloc[30:].to_numpy() - static.predict(X.iloc[30:]))
    online = online_compensation(RecursiveLS(forgetting=0.9).fit(X.iloc[:30], y.iloc[:30]),
                                 X.iloc[30:], y.iloc[30:], batch_size=5)
    assert online.run.after.mean_abs_um < 0.5 * static_residual.mean_abs_um
    assert online.run.after.max_abs_um < static_residual.max_abs_um


def test_online_bad_input(s3_workpieces):
    X, y = s3_workpieces
    model = RecursiveLS().fit(X, y)
    with pytest.raises(ProblemError, match="batch_size"):
        online_compensation(model, X, y, batch_size=0)
    with pytest.raises(ProblemError, match="150 rows but y_um has 149"):
        online_compensation(model, X, y.iloc[:-1])
