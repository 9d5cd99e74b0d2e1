"""The model whose gap is diagnosed (svrqp.gap.model): the baseline and its refits, and the per-run
recalibrations fitted on the real rows (the discrepancy base, each model input alone)."""

import re

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.svm import SVR
from support.gap_problems import CANDIDATES, air_lag_problem

from svrqp import datasets
from svrqp.exceptions import ProblemError
from svrqp.gap import GapQuestion, diagnose
from svrqp.gap.data.prepare import prepare
from svrqp.gap.data.runs import blocked_folds
from svrqp.gap.data.transforms import smooth
from svrqp.gap.model import LSSVR_C, SVR_C, SVR_EPSILON, fit_baseline


# -- the baseline ----------------------------------------------------------------------------------


FEATURES = ["spindle_C", "nut_C"]


@pytest.fixture(scope="module")
def data():
    """The air-lag problem, a two-feature model fitted on run r0 (240 rows)."""
    question = GapQuestion(target="error_um", train="run == 'r0'", features=FEATURES,
                           candidates=[c for c in CANDIDATES if c not in FEATURES], order="time_min", group="run")
    return prepare(air_lag_problem(), question)


def standardised(data):
    """Train-row standardisation of the features and the target, as the documented pipeline does."""
    train = data.is_train
    mean, std = data.X[train].mean(axis=0), data.X[train].std(axis=0)
    y_mean, y_std = data.y[train].mean(), data.y[train].std()
    return (data.X - mean) / std, (data.y - y_mean) / y_std, y_mean, y_std


def test_mlr_baseline_is_ordinary_least_squares(data):
    baseline = fit_baseline(data, "mlr")
    reference = LinearRegression().fit(data.X[data.is_train], data.y[data.is_train]).predict(data.X)
    np.testing.assert_allclose(baseline.y_hat, reference, atol=1e-9 * np.abs(data.y).max())
    np.testing.assert_allclose(baseline.residual, data.y - baseline.y_hat)


def test_svr_baseline_matches_libsvm(data):
    Z, t, y_mean, y_std = standardised(data)
    train = data.is_train
    reference = SVR(C=SVR_C, epsilon=SVR_EPSILON, gamma=1.0 / Z.shape[1], tol=1e-8).fit(Z[train], t[train])
    expected = y_mean + y_std * reference.predict(Z)
    np.testing.assert_allclose(fit_baseline(data, "svr").y_hat, expected, atol=1e-5 * data.y[train].std())


def test_lssvr_baseline_solves_the_kkt_system(data):
    """S4 eqs. (4)–(7): [[0, 1ᵀ], [1, K + I/C]]·[b; α] = [0; y], solved here by numpy."""
    Z, t, y_mean, y_std = standardised(data)
    train = data.is_train
    Zt = Z[train]
    gamma = 1.0 / Z.shape[1]
    K = np.exp(-gamma * ((Zt[:, None, :] - Zt[None, :, :]) ** 2).sum(axis=2))
    n = train.sum()
    M = np.block([[np.zeros((1, 1)), np.ones((1, n))], [np.ones((n, 1)), K + np.eye(n) / LSSVR_C]])
    b, *alpha = np.linalg.solve(M, np.concatenate([[0.0], t[train]]))
    K_all = np.exp(-gamma * ((Z[:, None, :] - Zt[None, :, :]) ** 2).sum(axis=2))
    expected = y_mean + y_std * (K_all @ np.array(alpha) + b)
    np.testing.assert_allclose(fit_baseline(data, "lssvr").y_hat, expected, atol=1e-8 * data.y[train].std())


def test_unknown_model_kind_is_named(data):
    with pytest.raises(ProblemError, match="model: unknown kind 'gp'"):
        fit_baseline(data, "gp")


# -- recalibrations on the real rows ---------------------------------------------------------------


MIAO = {"target": "error_um", "train": "batch == 'x1'", "features": ["T7_C", "T9_C"],
        "candidates": ["T1_C", "T2_C", "T3_C", "T4_C", "T5_C", "T6_C", "T8_C"], "order": "time_min",
        "group": "batch"}


@pytest.fixture(scope="module")
def miao():
    df = datasets.load("miao2013")
    return df, diagnose(df, GapQuestion(**MIAO))


def test_ranges_are_those_of_the_train_and_real_rows(miao):
    df, report = miao
    train = df["batch"] == "x1"
    ambient = next(u for u in report.inputs if u.column == "T9_C")
    assert ambient.train_low == df.loc[train, "T9_C"].min() and ambient.train_high == df.loc[train, "T9_C"].max()
    assert ambient.real_low == df.loc[~train, "T9_C"].min() and ambient.real_high == df.loc[~train, "T9_C"].max()
    outside = (df.loc[~train, "T9_C"] < ambient.train_low) | (df.loc[~train, "T9_C"] > ambient.train_high)
    assert ambient.outside == pytest.approx(outside.mean())


def test_s0_story_the_autumn_gap_is_the_ambient_input_used_beyond_its_summer_range(miao):
    """S0: an MLR fitted in summer, when the air hardly moved, cannot know what autumn air does."""
    _, report = miao
    ambient = next(u for u in report.inputs if u.column == "T9_C")
    assert ambient.extrapolated  # the autumn batch is far below the summer range
    others = [u for u in report.inputs if u.column != "T9_C" and u.role == "input"]
    assert all(ambient.recalibration_shrink > u.recalibration_shrink for u in others)
    assert ambient.recalibration_shrink > 0.5
    # Its own part, beyond the per-batch offsets (which alone take much of a level per batch).
    assert all(ambient.beyond_offsets > u.beyond_offsets for u in others) and ambient.beyond_offsets > 0.3
    # The summary (two sentences) leads with extrapolation only when a refit on more data removes most of
    # the gap; here the held-out autumn batch lies outside the other batches' range too, so the reason says it.
    assert "T9_C" in report.verdict.reason and "outside its train range" in report.verdict.reason
    assert "of what one offset per batch alone leaves" in report.verdict.reason
    assert report.to_dict()["inputs"][1]["extrapolated"] is True


def test_recalibration_shrinks_equal_an_independent_fold_by_fold_refit(miao):
    df, report = miao
    real = (df["batch"] != "x1").to_numpy()
    ordered = df.sort_values(["batch", "time_min"], kind="stable")
    groups = ordered["batch"].map({"x1": 0, "x2": 1, "x3": 2}).to_numpy()
    r = ordered["error_um"].to_numpy() - report.series.y_hat  # the series is sorted the same way
    x = ordered["T9_C"].to_numpy(float)
    real = groups > 0
    columns = np.column_stack([groups[real] == 1, groups[real] == 2, x[real], smooth(x, groups)[real]]).astype(float)

    def rmse_out_of_sample(design):
        errors = np.empty(int(real.sum()))
        for test in blocked_folds(groups[real] - 1):
            fit = np.setdiff1d(np.arange(errors.size), test)
            model = LinearRegression(fit_intercept=False).fit(design[fit], r[real][fit])
            errors[test] = r[real][test] - model.predict(design[test])
        return np.sqrt(np.mean(errors**2))

    ambient = next(u for u in report.inputs if u.column == "T9_C")
    with_input, offsets_only = rmse_out_of_sample(columns), rmse_out_of_sample(columns[:, :2])
    assert ambient.recalibration_shrink == pytest.approx(1 - with_input / np.sqrt(np.mean(r[real] ** 2)), abs=1e-6)
    assert ambient.beyond_offsets == pytest.approx(1 - with_input / offsets_only, abs=1e-6)


def test_inputs_within_their_range_are_not_called_extrapolated():
    report = diagnose(air_lag_problem(), GapQuestion(target="error_um", train="run == 'r0'", features=["spindle_C"],
                                                     candidates=CANDIDATES, order="time_min", group="run"))
    assert [u.column for u in report.inputs if u.role == "input"] == ["spindle_C"]
    assert "outside its train range" not in report.verdict.reason or report.inputs[0].extrapolated


def test_prediction_mode_lists_the_candidates_only():
    df = air_lag_problem()
    df["prediction_um"] = 2.0 * df["spindle_C"]
    report = diagnose(df, GapQuestion(target="error_um", train="run == 'r0'", prediction="prediction_um",
                                      candidates=CANDIDATES, order="time_min", group="run"))
    assert [u.column for u in report.inputs] == CANDIDATES and {u.role for u in report.inputs} == {"candidate"}


def test_s0_story_the_start_up_transient_of_the_summer_batch_is_localised(miao):
    """S0: the MLR residual peaks in the first 10 min of a run. Pooled over both real batches the
    autumn drift hides it; within the summer batch x2 it is where the error concentrates."""
    df, report = miao
    within = [r for r in report.where if r.group is not None]
    start = next(r for r in within if r.group == "x2")
    assert start.column == "time_min" and start.low == 0.0 and start.high <= 20.0
    residual = df["error_um"] - report.series.y_hat[np.argsort(np.lexsort((df["time_min"], df["batch"])))]
    x2 = (df["batch"] == "x2").to_numpy()
    first = x2 & (df["time_min"] <= start.high).to_numpy()
    assert start.rmse == pytest.approx(np.sqrt(np.mean(residual[first] ** 2)))
    assert start.rmse > 2 * np.sqrt(np.mean(residual[x2 & ~first] ** 2))
    assert f"| time_min | x2 | {start.low:.4g} | {start.high:.4g} |" in report.to_markdown()


def test_without_a_group_the_offset_is_worded_as_one_offset():
    """No --group (nor --order): the real rows are one group, so the base holds one offset, not one per group."""
    df = datasets.load("miao2013")
    args = {k: v for k, v in MIAO.items() if k not in ("group", "order")} | {"candidates": ["T1_C", "T8_C"]}
    report = diagnose(df, GapQuestion(**args))
    assert report.base.description.startswith("one offset and")
    assert "held-out blocks" in report.summary and "per group" not in report.verdict.reason
    assert report.blocks["kind"] == "blocks" and report.blocks["n"] >= 5


def test_a_recalibration_that_removes_nothing_is_said_so_not_printed_as_a_negative_shrink():
    """Summer x2 and the first ten autumn minutes: T9_C is outside its summer range on most real
    rows, but over so short an autumn stretch refitting it predicts nothing the offsets do not."""
    df = datasets.load("miao2013")
    df = df[(df["batch"] != "x3") | (df["time_min"] < 10)]
    report = diagnose(df, GapQuestion(**MIAO | {"candidates": ["T1_C", "T8_C"]}))
    ambient = next(u for u in report.inputs if u.column == "T9_C")
    assert ambient.extrapolated and ambient.beyond_offsets <= 0
    assert "recalibrating it removes nothing out of sample beyond what one offset per batch alone does" \
        in report.verdict.reason
    assert not re.search(r"-\d", report.verdict.reason.split("outside its train range")[-1])  # no negative share


def test_a_refit_that_makes_the_error_larger_is_said_so():
    """Refitted on summer x1 alone, the level of T8_C cannot be learned for autumn: the verdict's
    refit on the train rows makes the real-row error larger, and its reason says so in words. (Without
    --group: with it, only two real batches hold the transfer evidence and no verdict is named.)"""
    df = datasets.load("miao2013")
    report = diagnose(df, GapQuestion(**{k: v for k, v in MIAO.items() if k not in ("group", "order")}))
    assert report.verdict.column is not None
    assert report.verdict.refit_shrink < 0
    assert "makes the real-row error larger" in report.verdict.reason
    assert "shrinks it by -" not in report.verdict.reason
