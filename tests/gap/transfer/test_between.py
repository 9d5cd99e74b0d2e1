"""Evidence between runs for candidates constant within each run (svrqp.gap.transfer.between)."""

import numpy as np
import pytest
from support.gap_problems import AXIS_CANDIDATES, AXIS_POSITIONS_MM, SCALE_UM_PER_K_MM, axis_passes
from numpy.polynomial import legendre
from scipy import stats
from sklearn.linear_model import LinearRegression

from svrqp.gap import GapQuestion, diagnose
from svrqp.gap.contract import EVIDENCE_BETWEEN, MIN_RUNS, PROFILE_DEGREE
from svrqp.gap.data.prepare import prepare
from svrqp.gap.data.runs import blocked_folds
from svrqp.gap.transfer.between import (
    between_run_test,
    is_run_level,
    moves_beyond_noise,
    noise_variance,
    profile_columns,
    run_level_bank,
    within_share,
)
from svrqp.gap.transfer.candidates import effect_columns
from svrqp.gap.within.surrogate_tests import BetweenRunTest

ARGS = {"target": "error_um", "train": "run == 'p0'", "prediction": "prediction_um", "order": "x_mm", "group": "run"}


def _runs(k: int, m: int) -> np.ndarray:
    return np.repeat(np.arange(k), m)


def test_a_reading_constant_within_runs_is_run_level_and_a_drifting_one_is_not():
    groups = _runs(5, 40)
    rng = np.random.default_rng(0)
    per_run = np.repeat(rng.normal(scale=3.0, size=5), 40)
    assert within_share(per_run, groups) == pytest.approx(0.0, abs=1e-12)
    assert is_run_level(per_run + 0.01 * rng.normal(size=200), groups)
    ramp = np.tile(np.linspace(0.0, 5.0, 40), 5)
    assert within_share(ramp, groups) == pytest.approx(1.0)
    assert not is_run_level(ramp + per_run, groups)
    assert not is_run_level(np.full(200, 21.0), groups)  # a constant carries nothing


def test_profile_runs_from_minus_one_to_one_in_every_run():
    groups = _runs(3, 11)
    t = np.concatenate([np.linspace(0, 10, 11), np.linspace(5, 6, 11), np.linspace(0, 100, 11) ** 1.5])
    P = profile_columns(t, groups)
    assert P.shape == (33, PROFILE_DEGREE)
    for start in (0, 11, 22):
        assert P[start, 0] == pytest.approx(-1.0) and P[start + 10, 0] == pytest.approx(1.0)
        assert P[start, 1] == pytest.approx(1.0)  # P2(-1) = 1


def _reference_p_value(r: np.ndarray, groups: np.ndarray, t: np.ndarray, c: np.ndarray) -> float:
    """The four steps of the test, written again with scikit-learn, legfit and linregress."""
    k = len(np.unique(groups))
    u = np.concatenate([np.linspace(-1, 1, np.sum(groups == g)) for g in range(k)])
    profile = np.column_stack([legendre.legval(u, np.eye(PROFILE_DEGREE + 1)[j]) for j in range(1, PROFILE_DEGREE + 1)])
    cleared = r - LinearRegression().fit(profile, r).predict(profile)
    summaries = np.array([legendre.legfit(u[groups == g], cleared[groups == g], PROFILE_DEGREE) for g in range(k)])
    centred = summaries - summaries.mean(axis=0)
    score = centred @ np.linalg.svd(centred)[2][0]
    level = np.array([c[groups == g].mean() for g in range(k)])
    return stats.linregress(level, score).pvalue


def test_p_value_equals_an_independent_implementation_of_the_same_test():
    rng = np.random.default_rng(3)
    groups, m = _runs(6, 30), 30
    t = np.tile(np.linspace(0.0, 300.0, m), 6)
    c = np.repeat(rng.uniform(20, 28, size=6), m) + 0.01 * rng.normal(size=6 * m)
    bow = 1 - np.tile(np.linspace(-1, 1, m), 6) ** 2
    for r in (0.2 * (c - 20) * bow + rng.normal(scale=0.3, size=6 * m), rng.normal(size=6 * m)):
        bank = run_level_bank("c", c, t, groups)
        ours = between_run_test(r, np.ones((6 * m, 1)), groups, bank).p_value
        # Legendre summaries on a different basis span (legfit's degree 0…D) give the same fits.
        assert ours == pytest.approx(_reference_p_value(r, groups, t, c), rel=1e-8)


def test_false_positive_rate_under_the_null_is_near_the_level():
    rng = np.random.default_rng(11)
    groups, m, k = _runs(6, 25), 25, 6
    t = np.tile(np.arange(m, dtype=float), k)
    p = []
    for _ in range(400):
        c = np.repeat(rng.uniform(20, 30, size=k), m)
        r = rng.normal(size=k * m) + np.repeat(rng.normal(size=k), m)  # noise plus unrelated run offsets
        p.append(between_run_test(r, np.ones((k * m, 1)), groups, run_level_bank("c", c, t, groups)).p_value)
    p = np.array(p)
    assert 0.025 <= np.mean(p < 0.05) <= 0.085
    assert 0.07 <= np.mean(p < 0.1) <= 0.14


def test_too_few_runs_give_no_evidence():
    groups = _runs(MIN_RUNS - 1, 30)
    t = np.tile(np.arange(30.0), MIN_RUNS - 1)
    c = np.repeat([20.0, 24.0, 28.0], 30)
    r = 0.1 * (c - 20) * t
    assert between_run_test(r, np.ones((r.size, 1)), groups, run_level_bank("c", c, t, groups)).p_value == 1.0


def test_one_extreme_run_cannot_carry_a_relation_past_the_floor():
    """An anomalous profile in the one run where an unrelated reading is extreme: the t test may
    see a slope, but the others cannot predict that run, so the out-of-sample floor fails."""
    rng = np.random.default_rng(5)
    k, m = 6, 40
    groups = _runs(k, m)
    t = np.tile(np.linspace(0.0, 1.0, m), k)
    c = np.repeat([21.0, 21.3, 20.8, 21.1, 20.9, 27.0], m)
    r = rng.normal(scale=0.2, size=k * m)
    r[groups == 5] += 3.0 * np.sin(np.pi * t[groups == 5]) ** 8  # an unrelated anomaly in the last run
    test = BetweenRunTest(r, np.ones((k * m, 1)), blocked_folds(groups), groups, run_level_bank("c", c, t, groups))
    assert test.p_value < 0.05  # the t test alone takes the extreme run for evidence
    assert not test.robust  # without that run there is no relation
    assert not test.outcome().robust


@pytest.fixture(scope="module")
def scale_report():
    return diagnose(axis_passes("scale", runs=7, seed=1), GapQuestion(candidates=AXIS_CANDIDATES, **ARGS))


def test_scale_expansion_is_named_between_runs(scale_report):
    verdict = scale_report.verdict
    assert verdict.column == "axis_C"
    assert verdict.transform == "level" and verdict.evidence == EVIDENCE_BETWEEN
    assert verdict.shrink > 0.8
    top = scale_report.causes[0]
    assert top.column == "axis_C" and top.significant and top.evidence == EVIDENCE_BETWEEN
    assert "constant within each run" in scale_report.summary
    document = scale_report.to_dict()
    assert document["verdict"]["evidence"] == EVIDENCE_BETWEEN


def test_scale_shrink_matches_the_true_effect_refitted_out_of_sample(scale_report):
    """Cross-check (DESIGN §4 transfer shrink): the discrepancy target − prediction refitted leave-one-run-out
    over all rows with the true effect column as the only regressor, scored on the real rows."""
    df = axis_passes("scale", runs=7, seed=1)
    real = (df["run"] != "p0").to_numpy()
    d = (df["error_um"] - df["prediction_um"]).to_numpy()
    D = np.column_stack([np.ones(d.size), df["effect_um"].to_numpy()])
    runs = df["run"].to_numpy()
    errors = np.empty(d.size)
    for run in np.unique(runs[real]):
        test = runs == run
        errors[test] = d[test] - D[test] @ np.linalg.lstsq(D[~test], d[~test], rcond=None)[0]
    oracle = 1 - np.sqrt(np.mean(errors[real] ** 2)) / np.sqrt(np.mean(d[real] ** 2))
    assert scale_report.verdict.shrink == pytest.approx(oracle, abs=0.03)


def test_with_three_real_runs_the_reading_is_reported_untestable():
    report = diagnose(axis_passes("scale", runs=4, seed=0), GapQuestion(candidates=AXIS_CANDIDATES, **ARGS))
    assert report.verdict.column is None
    note = next(c.note for c in report.causes if c.column == "axis_C")
    assert f"needs at least {MIN_RUNS} real runs (3 here)" in note


def test_null_passes_name_nothing():
    for seed in range(3):
        report = diagnose(axis_passes("none", runs=7, seed=seed), GapQuestion(candidates=AXIS_CANDIDATES, **ARGS))
        assert report.verdict.column is None


def test_refit_columns_of_a_run_level_effect_are_the_block_on_every_row():
    df = axis_passes("scale", runs=5, seed=2)
    data = prepare(df, GapQuestion(candidates=AXIS_CANDIDATES, **ARGS))
    block = effect_columns(data, "axis_C", "level", None, EVIDENCE_BETWEEN)
    assert block.shape == (len(df), 2 * PROFILE_DEGREE + 1)
    first = data.groups == 0
    axis = df.loc[df["run"] == "p0", "axis_C"].mean()
    np.testing.assert_allclose(block[first, PROFILE_DEGREE], axis)  # the run mean, on the train pass too
    assert np.ptp(block[:, PROFILE_DEGREE]) > 1.0
    assert SCALE_UM_PER_K_MM > 0 and AXIS_POSITIONS_MM[-1] == 500.0


def test_a_true_relation_survives_without_its_most_extreme_run():
    """Four warm passes and one cold one: the amplitude follows the temperature among the warm ones too."""
    rng = np.random.default_rng(6)
    k, m = 5, 60
    groups = _runs(k, m)
    t = np.tile(np.linspace(0.0, 1.0, m), k)
    c = np.repeat([26.7, 27.2, 27.4, 27.2, 20.4], m)
    r = 0.4 * (c - 20.0) * 4 * t * (1 - t) + rng.normal(scale=0.05, size=k * m)
    result = between_run_test(r, np.ones((k * m, 1)), groups, run_level_bank("c", c, t, groups))
    assert result.p_value < 1e-3 and result.robust


def test_a_reading_drifting_within_runs_beyond_its_noise_is_told_from_one_at_its_noise():
    """Both hold their run levels (under 5 % of the variance within runs); one also drifts slowly
    through each run, far beyond its 0.01 °C reading noise, the other only jitters by that noise."""
    rng = np.random.default_rng(5)
    groups = np.repeat(np.arange(4), 60)
    levels = np.repeat([20.0, 26.0, 23.0, 29.0], 60)
    jitter = 0.01 * rng.normal(size=240)
    drift = np.tile(np.linspace(0.0, 0.6, 60), 4)
    assert noise_variance(levels + jitter, groups) == pytest.approx(1e-4, rel=0.3)
    assert is_run_level(levels + drift + jitter, groups) and moves_beyond_noise(levels + drift + jitter, groups)
    assert is_run_level(levels + jitter, groups) and not moves_beyond_noise(levels + jitter, groups)
