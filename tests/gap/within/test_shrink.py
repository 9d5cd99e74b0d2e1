"""Out-of-sample shrink within the real rows and its bootstrap interval (svrqp.gap.within.attribute), and the
verdict's refit check on the train rows (svrqp.gap.model.refit_shrink)."""

import numpy as np
import pytest
from support.gap_problems import CANDIDATES, air_lag_problem, first_order_lag

from svrqp.gap import GapQuestion, diagnose
from svrqp.gap.contract import EVIDENCE_WITHIN
from svrqp.gap.data.discrepancy import nested_errors
from svrqp.gap.data.prepare import prepare
from svrqp.gap.data.runs import blocked_folds
from svrqp.gap.model import fit_baseline, refit_shrink
from svrqp.gap.transfer.candidates import effect_columns
from svrqp.gap.within.attribute import estimate_shrink, shrink_interval

N = 800
GROUPS = np.repeat(np.arange(4), 200)


def _problem(seed=0):
    rng = np.random.default_rng(seed)
    B = np.ones((N, 1))
    z = rng.normal(size=N)
    r = 2.0 * z + rng.normal(scale=0.5, size=N)
    return r, B, z


def test_nested_errors_with_one_variant_equal_fold_by_fold_least_squares():
    r, B, z = _problem()
    folds = blocked_folds(GROUPS)
    errors = nested_errors(r, B, z[:, None], None, folds, GROUPS)
    for test in folds:
        train = np.setdiff1d(np.arange(N), test)
        D = np.column_stack([B, z])
        coef = np.linalg.lstsq(D[train], r[train], rcond=None)[0]
        np.testing.assert_allclose(errors[test], r[test] - D[test] @ coef, rtol=1e-10, atol=1e-12)


def test_shrink_of_a_perfect_effect_is_one_minus_noise_over_rmse():
    r, B, z = _problem()
    after = nested_errors(r, B, z[:, None], None, blocked_folds(GROUPS), GROUPS)
    estimate = estimate_shrink(r, after, GROUPS, np.random.default_rng(0))
    expected = 1 - 0.5 / np.sqrt(np.mean(r**2))
    assert estimate.shrink == pytest.approx(expected, abs=0.02)
    assert estimate.ci_low <= estimate.shrink <= estimate.ci_high
    assert estimate.rmse_before == pytest.approx(np.sqrt(np.mean(r**2)))


def test_useless_column_does_not_shrink():
    r, B, _ = _problem()
    junk = np.random.default_rng(9).normal(size=N)
    after = nested_errors(r - r.mean(), B, junk[:, None], None, blocked_folds(GROUPS), GROUPS)
    estimate = estimate_shrink(r - r.mean(), after, GROUPS, np.random.default_rng(0))
    assert abs(estimate.shrink) < 0.02
    assert estimate.ci_low < 0.01


def test_nested_choice_picks_the_informative_variant():
    r, B, z = _problem()
    rng = np.random.default_rng(4)
    variants = np.column_stack([rng.normal(size=N), z, rng.normal(size=N)])
    errors = nested_errors(r, B, variants, None, blocked_folds(GROUPS), GROUPS)
    assert np.sqrt(np.mean(errors**2)) == pytest.approx(0.5, rel=0.1)


def test_bootstrap_interval_of_identical_errors_is_a_point():
    e = np.random.default_rng(2).normal(size=N)
    low, high = shrink_interval(e, e, GROUPS, np.random.default_rng(0))
    assert low == pytest.approx(0.0, abs=1e-12) and high == pytest.approx(0.0, abs=1e-12)


def test_refit_shrink_equals_an_independent_least_squares_refit():
    df = air_lag_problem()
    data = prepare(df, GapQuestion(target="error_um", train="run == 'r0'", features=["spindle_C"],
                                   candidates=CANDIDATES, order="time_min", group="run"))
    baseline = fit_baseline(data, "mlr")
    shrink = refit_shrink(data, baseline, effect_columns(data, "air_C", "lag", 60.0, EVIDENCE_WITHIN))
    # independent: lstsq with [1, spindle, air, lowpass(air) - air] per run via scipy's lfilter
    train, real = (df["run"] == "r0").to_numpy(), (df["run"] != "r0").to_numpy()
    air = df["air_C"].to_numpy()
    lowpass = np.concatenate([first_order_lag(air[df["run"] == run], 60.0) for run in df["run"].unique()])
    D = np.column_stack([np.ones(len(df)), df["spindle_C"], air, lowpass - air])
    coef = np.linalg.lstsq(D[train], df["error_um"].to_numpy()[train], rcond=None)[0]
    after = np.sqrt(np.mean((df["error_um"].to_numpy() - D @ coef)[real] ** 2))
    before = np.sqrt(np.mean(baseline.residual[data.is_real] ** 2))
    assert shrink == pytest.approx(1 - after / before, rel=1e-6)


def test_a_candidate_recorded_on_the_real_rows_only_is_diagnosed_but_not_refitted():
    """The same verdict as with the full record, except that the verdict's refit on the train rows cannot
    be made and is said not to be. The transfer refits with the effect use the rows where it is recorded
    (the real runs), so its shrink is that of a fit that never saw the train run."""
    # Without coolant_C: recorded on every row and following the air, it transfers a little better than an
    # air reading whose refits see the real runs only, which is not what this test is about.
    args = {"target": "error_um", "train": "run == 'r0'", "features": ["spindle_C"],
            "candidates": [c for c in CANDIDATES if c != "coolant_C"], "order": "time_min", "group": "run"}
    df = air_lag_problem()
    full = diagnose(df, GapQuestion(**args))
    late = diagnose(df.assign(air_C=df["air_C"].where(df["run"] != "r0")), GapQuestion(**args))
    assert late.verdict.column == full.verdict.column == "air_C" and late.n_dropped == 0
    assert 0 < late.verdict.shrink <= 1 and late.verdict.shrink != full.verdict.shrink
    assert full.verdict.refit_shrink is not None and late.verdict.refit_shrink is None
    assert "cannot be refitted with it as an input, since air_C is not recorded on every train row" in late.verdict.reason
    late.to_dict()  # schema-valid with the refit left out
