"""Paired block-bootstrap test of two causes' out-of-sample losses (svrqp.gap.compare).

Errors are AR(1) series (autocorrelated like real residuals) in four groups: two models whose
errors have the same distribution cannot be told apart; a model with twice the error can.
"""

import numpy as np
from scipy.signal import lfilter

from svrqp.gap.compare import TIE_ALPHA, paired_loss_test

GROUPS = np.repeat([0, 1, 2, 3], 200)


def ar1_errors(seed: int, phi: float = 0.6) -> np.ndarray:
    """Unit-variance AR(1) errors with lag-1 autocorrelation ``phi``."""
    shocks = np.random.default_rng(seed).normal(scale=np.sqrt(1 - phi**2), size=GROUPS.size)
    return lfilter([1.0], [1.0, -phi], shocks)


def test_equally_good_models_are_tied():
    ties = [paired_loss_test(ar1_errors(s), ar1_errors(s + 100), GROUPS, np.random.default_rng(s)).tied
            for s in range(20)]
    assert sum(ties) >= 16  # nominal 95 %; a loose bound keeps the test meaningful but not flaky


def test_a_clearly_worse_model_is_not_tied():
    e_a = ar1_errors(1)
    result = paired_loss_test(e_a, 2 * ar1_errors(2), GROUPS, np.random.default_rng(0))
    assert not result.tied and result.p_value < TIE_ALPHA
    assert result.mean_difference > 0 and result.ci_low > 0


def test_mean_difference_is_the_mean_loss_difference():
    e_a, e_b = ar1_errors(3), ar1_errors(4)
    result = paired_loss_test(e_a, e_b, GROUPS, np.random.default_rng(0))
    assert np.isclose(result.mean_difference, np.mean(e_b**2 - e_a**2))
    assert result.ci_low <= result.mean_difference <= result.ci_high
