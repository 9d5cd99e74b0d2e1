"""Steps 2 and 3 (svrqp.gap.detect): the gap tests on residuals (excess error, noise level, whiteness),
and where the real-row error concentrates (honest 1-D error trees)."""

import numpy as np
import pytest
from scipy import stats
from scipy.signal import lfilter

from svrqp.gap.data.runs import blocked_folds
from svrqp.gap.detect import (
    MIN_LEAF_FRACTION,
    effective_size,
    gap_detected,
    gate,
    ljung_box_pvalue,
    localise,
    noise_pvalue,
    regions_on,
    successive_difference_variance,
    within_run_fit_half,
)
from svrqp.gap.results.records import Region

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


# -- where the error concentrates

N_RUN = 300
T = np.tile(np.arange(N_RUN, dtype=float), 2)  # two runs of 300 min
GROUPS = np.repeat([0, 1], N_RUN)


def _transient_residual(seed=0):
    """Noise 0.2 everywhere plus a start-up transient 3·exp(-t/15) in the first minutes of each run."""
    rng = np.random.default_rng(seed)
    return 3.0 * np.exp(-T / 15.0) + 0.2 * rng.normal(size=T.size)


def test_a_start_up_transient_is_found_at_the_start():
    e = _transient_residual()
    where = localise(e, "time_min", T, {}, blocked_folds(GROUPS), GROUPS)
    first = where[0]
    assert first.column == "time_min"
    assert first.low == 0.0 and first.high <= 40.0
    assert first.share > 0.7


def test_region_numbers_are_computed_on_every_real_row():
    e = _transient_residual()
    first = localise(e, "time_min", T, {}, blocked_folds(GROUPS), GROUPS)[0]
    inside = (T >= first.low) & (T <= first.high)
    assert first.n == inside.sum()
    assert first.rmse == pytest.approx(np.sqrt(np.mean(e[inside] ** 2)))
    assert first.share == pytest.approx(np.sum(e[inside] ** 2) / np.sum(e**2))


def test_uniform_error_is_reported_as_the_whole_range():
    e = np.random.default_rng(1).normal(size=T.size)
    where = localise(e, "time_min", T, {}, blocked_folds(GROUPS), GROUPS)
    assert any(r.column == "time_min" for r in where)
    spans = [r for r in where if r.column == "time_min"]
    # either nothing stands out (one region, everything) or what stands out is weak
    assert len(spans) == 1 and spans[0].share == pytest.approx(1.0) or all(r.enrichment < 1.6 for r in spans)


def test_a_candidate_region_is_reported_when_error_follows_it():
    e = _transient_residual()
    hot = np.where(T < 20, 40.0, 25.0) + np.random.default_rng(2).normal(scale=0.5, size=T.size)
    where = localise(e, "time_min", T, {"spindle_C": hot}, blocked_folds(GROUPS), GROUPS)
    spindle = [r for r in where if r.column == "spindle_C"]
    assert spindle and spindle[0].low > 35.0


def test_regions_are_scored_on_held_out_rows():
    # with an error that depends on nothing, held-out enrichment hovers around 1
    rng = np.random.default_rng(3)
    e = rng.normal(size=T.size)
    fit_rows = np.arange(T.size) % 2 == 0
    for region in regions_on("time_min", T, e, fit_rows):
        assert isinstance(region, Region)
        assert region.enrichment == pytest.approx(1.0, abs=0.6)


def test_a_stretch_where_only_one_of_two_runs_goes_wrong_is_one_region():
    """Run 1 steps 3 μm away at 150 min, run 0 stays at the noise: pooled along time, the error
    concentrates on 150 … 299. Scoring each stretch on the rows of both runs keeps it one region
    (blocks interleaved within runs scored stretches on one run only and cut holes into it)."""
    rng = np.random.default_rng(0)
    e = 0.2 * rng.normal(size=T.size) + np.where((GROUPS == 1) & (T >= 150), 3.0, 0.0)
    spans = [r for r in localise(e, "time_min", T, {}, blocked_folds(GROUPS), GROUPS) if r.column == "time_min"]
    assert len(spans) == 1
    assert 140 <= spans[0].low <= 165 and spans[0].high == T.max()
    assert spans[0].share > 0.9  # blocks interleaved within runs gave 183 … 269 and 58 %


def _summer_and_autumn_residual(seed=0):
    """Run 0: noise 0.2 and a 2 μm start-up transient in its first 10 min; run 1: a drift to 6 μm
    over the run (S0's autumn batch), which dominates the error pooled over both runs."""
    rng = np.random.default_rng(seed)
    transient = np.where((GROUPS == 0) & (T < 10), 2.0, 0.0)
    drift = np.where(GROUPS == 1, 6.0 * T / N_RUN, 0.0)
    return transient + drift + 0.2 * rng.normal(size=T.size)


def test_a_start_up_transient_in_one_run_is_found_within_that_run():
    e = _summer_and_autumn_residual()
    where = localise(e, "time_min", T, {}, blocked_folds(GROUPS), GROUPS, ["summer", "autumn"])
    pooled = [r for r in where if r.group is None]
    assert pooled[0].low > 50.0  # pooled over the runs, the autumn drift is where the error is
    within = [r for r in where if r.group is not None]
    assert len(within) == 1
    start = within[0]
    assert start.group == "summer" and start.low == 0.0 and 8.0 <= start.high <= 20.0
    inside = (GROUPS == 0) & (T >= start.low) & (T <= start.high)
    assert start.n == inside.sum()
    assert start.share == pytest.approx(np.sum(e[inside] ** 2) / np.sum(e**2))
    assert start.share_of_run == pytest.approx(np.sum(e[inside] ** 2) / np.sum(e[GROUPS == 0] ** 2))
    assert start.share_of_run > 0.5 > start.share


def test_no_region_within_a_run_when_its_error_is_even():
    rng = np.random.default_rng(4)
    e = rng.normal(size=T.size) * np.where(GROUPS == 1, 3.0, 1.0)
    assert [r for r in localise(e, "time_min", T, {}, blocked_folds(GROUPS), GROUPS) if r.group is not None] == []


def test_a_region_pooled_over_the_runs_is_not_repeated_for_one_run():
    e = _transient_residual()  # the same transient in both runs: one pooled region says it all
    where = localise(e, "time_min", T, {}, blocked_folds(GROUPS), GROUPS)
    assert where[0].group is None and where[0].low == 0.0
    assert all(r.group is None for r in where)


def test_within_run_halves_leave_no_leaf_without_held_out_rows():
    for n in (40, 251, 1000):
        fit = within_run_fit_half(n)
        leaf = int(np.ceil(MIN_LEAF_FRACTION * fit.sum()))
        # every stretch as long as a leaf's fitting rows span holds a held-out row
        longest_fit_run = max(len(s) for s in "".join("f" if f else "h" for f in fit).split("h"))
        assert longest_fit_run <= leaf
