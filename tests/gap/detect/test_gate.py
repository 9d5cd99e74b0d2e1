"""Gap tests on residuals (svrqp.gap.detect.gate): excess error, noise level, whiteness."""

import numpy as np
import pytest
from scipy import stats
from scipy.signal import lfilter

from svrqp.gap.detect.gate import (
    effective_size,
    gap_detected,
    gate,
    ljung_box_pvalue,
    noise_pvalue,
    successive_difference_variance,
)

RNG_SEED = 11
ONE_GROUP = np.zeros(2000, int)


def _ar1(n, phi, rng):
    return lfilter([1.0], [1.0, -phi], rng.normal(size=n))


def test_effective_size_of_white_noise_is_the_sample_size():
    e = np.random.default_rng(RNG_SEED).normal(size=2000)
    assert effective_size(e, ONE_GROUP) == pytest.approx(2000, rel=0.1)


def test_effective_size_shrinks_with_autocorrelation():
    e = _ar1(2000, 0.8, np.random.default_rng(RNG_SEED))
    assert effective_size(e, ONE_GROUP) == pytest.approx(2000 * 0.2 / 1.8, rel=0.25)


def test_no_excess_when_real_and_train_rows_share_the_noise():
    rng = np.random.default_rng(RNG_SEED)
    result = gate(rng.normal(size=600), np.zeros(600, int), rng.normal(size=300), np.zeros(300, int))
    assert result.p_excess > 0.05
    assert result.ratio == pytest.approx(1.0, abs=0.15)
    assert not gap_detected(result)


def test_excess_when_real_error_is_larger():
    rng = np.random.default_rng(RNG_SEED)
    result = gate(2.0 * rng.normal(size=600), np.zeros(600, int), rng.normal(size=300), np.zeros(300, int))
    assert result.p_excess < 1e-6
    assert gap_detected(result)


def test_the_gate_is_one_sided_real_rows_no_worse_than_train_rows_are_no_gap():
    """A smooth error above the noise on the real rows is a gap only when the real rows fit worse than
    the train rows; as large (or larger) on the train rows, the noise test alone no longer fires it."""
    rng = np.random.default_rng(RNG_SEED)
    drift = 2 * np.sin(np.linspace(0, 12, 600))
    real = drift + rng.normal(size=600)
    for train_scale, detected in ((1.2, False), (0.5, True)):
        train = train_scale * (drift[:300] + rng.normal(size=300))
        result = gate(real, np.zeros(600, int), train, np.zeros(300, int))
        assert result.p_noise < 1e-6
        assert gap_detected(result) is detected


def test_successive_difference_variance_of_white_noise_and_a_smooth_drift():
    rng = np.random.default_rng(RNG_SEED)
    drift = 5 * np.sin(np.linspace(0, 3, 2000))
    assert successive_difference_variance(rng.normal(size=2000) + drift, ONE_GROUP) == pytest.approx(1.0, rel=0.1)


def test_noise_gate_sees_a_smooth_error_but_not_white_noise():
    rng = np.random.default_rng(RNG_SEED)
    assert noise_pvalue(rng.normal(size=2000), ONE_GROUP) > 0.05
    assert noise_pvalue(rng.normal(size=2000) + 3 * np.sin(np.linspace(0, 6, 2000)), ONE_GROUP) < 1e-6


def test_ljung_box_matches_the_textbook_formula_on_one_group():
    e = _ar1(500, 0.3, np.random.default_rng(RNG_SEED))
    H = 20
    d = e - e.mean()
    rho = np.array([np.dot(d[h:], d[:-h]) for h in range(1, H + 1)]) / np.dot(d, d)
    Q = 500 * 502 * np.sum(rho**2 / (500 - np.arange(1, H + 1)))
    assert ljung_box_pvalue(e, np.zeros(500, int), H) == pytest.approx(stats.chi2.sf(Q, H), rel=1e-9)


def test_ljung_box_is_uniform_ish_for_white_noise_and_tiny_for_ar1():
    rng = np.random.default_rng(RNG_SEED)
    white = [ljung_box_pvalue(rng.normal(size=400), np.zeros(400, int)) for _ in range(200)]
    assert 0.02 < np.mean(np.array(white) < 0.05) < 0.10
    assert ljung_box_pvalue(_ar1(400, 0.6, rng), np.zeros(400, int)) < 1e-6
