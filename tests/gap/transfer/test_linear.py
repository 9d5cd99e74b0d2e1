"""Transfer numbers of the gap diagnosis (svrqp.gap.transfer.linear, DESIGN §4) against independent refits.

Every reference here is plain :func:`numpy.linalg.lstsq` on the raw columns, refitted leave one
run out over all rows and scored on the real rows; lags are filtered by :func:`gap_problems.first_order_lag`
(scipy's lfilter), not by :mod:`svrqp.gap.data.transforms`.
"""

import numpy as np
import pandas as pd
import pytest
from support.gap_problems import CANDIDATES, air_lag_problem, extrapolation_problem, first_order_lag, null_problem

from svrqp.exceptions import ProblemError
from svrqp.gap import GapQuestion, diagnose, load_schema
from svrqp.gap.contract import MIN_BLOCKS
from svrqp.gap.transfer.linear import decorrelation_length

ARGS = {"target": "error_um", "train": "run == 'r0'", "features": ["spindle_C"], "order": "time_min", "group": "run"}


def _logo_rmse(df: pd.DataFrame, design: list[np.ndarray], real: np.ndarray) -> float:
    """Real-row RMSE of least squares on ``design`` (each item: the variants' columns; the fit keeps the
    variant with the smallest error on its own rows), leave one run out over all rows."""
    y = df["error_um"].to_numpy()
    runs = df["run"].to_numpy()
    squared = []
    for run in np.unique(runs[real]):
        test = runs == run
        best = min(((np.linalg.lstsq(D[~test], y[~test], rcond=None)[0], D) for D in design),
                   key=lambda fit: np.sum((y[~test] - fit[1][~test] @ fit[0]) ** 2))
        squared.append((y[test] - best[1][test] @ best[0]) ** 2)
    return float(np.sqrt(np.mean(np.concatenate(squared))))


@pytest.fixture(scope="module")
def air():
    df = air_lag_problem()
    return df, diagnose(df, GapQuestion(candidates=CANDIDATES, **ARGS))


def test_level_shrink_equals_an_independent_leave_one_run_out_refit(air):
    df, report = air
    real = (df["run"] != "r0").to_numpy()
    base = np.column_stack([np.ones(len(df)), df["spindle_C"]])
    y = df["error_um"].to_numpy()
    coef = np.linalg.lstsq(base[~real], y[~real], rcond=None)[0]
    before = np.sqrt(np.mean((y[real] - base[real] @ coef) ** 2))
    refit = _logo_rmse(df, [base], real)
    assert report.transfer["rmse_before"] == pytest.approx(before, rel=1e-9)
    assert report.transfer["rmse_refit"] == pytest.approx(refit, rel=1e-9)
    levels = [c for c in report.causes if c.transform == "level"]
    assert levels
    for cause in levels:
        after = _logo_rmse(df, [np.column_stack([base, df[cause.column]])], real)
        assert cause.rmse_after == pytest.approx(after, rel=1e-9)
        assert abs(cause.shrink - (1 - after / before)) < 1e-9
        assert abs(cause.shrink_beyond_refit - (1 - after / refit)) < 1e-9


def test_lag_shrink_chooses_tau_inside_each_fit_as_an_independent_refit_does(air):
    df, report = air
    real = (df["run"] != "r0").to_numpy()
    verdict = report.verdict
    assert verdict.column == "air_C" and verdict.transform == "lag"
    base = np.column_stack([np.ones(len(df)), df["spindle_C"]])
    x = df["air_C"].to_numpy()
    variants = []
    for tau in report.settings["taus"]:
        lagged = np.concatenate([first_order_lag(x[df["run"] == run], tau) for run in df["run"].unique()])
        variants.append(np.column_stack([base, x, lagged]))
    after = _logo_rmse(df, variants, real)
    assert verdict.rmse_after == pytest.approx(after, rel=1e-9)
    assert abs(verdict.shrink - (1 - after / verdict.rmse_before)) < 1e-9
    assert verdict.shrink_ci is None  # three held-out runs: too few for an interval
    assert "too few for an interval" in verdict.reason


def test_real_rows_that_fit_better_than_the_train_rows_are_no_gap():
    """The train run gets extra noise: the real rows fit better, and nothing may be named."""
    df = air_lag_problem()
    train = df["run"] == "r0"
    df.loc[train, "error_um"] += np.random.default_rng(0).normal(scale=6.0, size=int(train.sum()))
    report = diagnose(df, GapQuestion(candidates=CANDIDATES, **ARGS))
    assert report.gap.real_rmse < report.gap.train_rmse
    assert not report.gap_detected and report.verdict.column is None
    assert "no gap" in report.summary


def test_a_model_used_outside_its_data_is_said_first_and_no_candidate_is_named():
    question = GapQuestion(target="error_um", train="run == 'r0'", features=["x_C"], candidates=["air_C", "nut_C"],
                           order="time_min", group="run")
    report = diagnose(extrapolation_problem(), question)
    assert report.verdict.column is None
    second = report.summary.split(". ", 1)[1]
    assert second.startswith("The model is used outside its data (x_C")
    assert f"removes {report.transfer['shrink_refit']:.0%}" in second and report.transfer["shrink_refit"] > 0.5
    candidates = [u for u in report.inputs if u.role == "candidate"]
    assert [u.column for u in candidates] == ["air_C", "nut_C"]


def test_a_continuous_record_is_cut_into_contiguous_blocks_no_shorter_than_the_decorrelation_length():
    df = pd.concat([air_lag_problem(seed=5)] * 1, ignore_index=True)
    df["time_min"] = np.arange(len(df), dtype=float)  # one record, no runs
    report = diagnose(df, GapQuestion(target="error_um", train="time_min < 240", features=["spindle_C"],
                                      candidates=CANDIDATES, order="time_min"))
    blocks = report.blocks
    assert blocks["kind"] == "blocks" and blocks["n"] >= MIN_BLOCKS
    assert not blocks["shorter_than_decorrelation"] and blocks["rows_per_block"] >= blocks["decorrelation_rows"]
    assert f"{blocks['n']} held-out blocks" in report.summary
    assert report.to_dict()["blocks"] == blocks


def test_a_record_too_short_for_five_blocks_says_so_and_stays_schema_valid():
    df = null_problem().iloc[:300].copy()  # one train run and 60 real rows of a slow drift
    df["error_um"] += np.linspace(0, 20, len(df)) ** 2 / 20
    report = diagnose(df, GapQuestion(target="error_um", train="run == 'r0'", features=["spindle_C"],
                                      candidates=CANDIDATES, order="time_min", group="run"))
    assert report.blocks["n"] == MIN_BLOCKS and report.blocks["shorter_than_decorrelation"]
    assert "blocks shorter than the error's correlation" in report.summary
    assert "too short for 5 blocks" in report.verdict.reason
    report.to_dict()  # validated against the schema


@pytest.mark.parametrize("train, message", [("run == run", "every row"), ("run == 'none'", "no row")])
def test_groups_that_are_all_train_or_all_real_are_a_clear_error(train, message):
    with pytest.raises(ProblemError, match=message):
        diagnose(air_lag_problem(), GapQuestion(candidates=CANDIDATES, **ARGS | {"train": train}))


def test_groups_of_one_row_are_dropped_and_counted():
    df = air_lag_problem()
    df.loc[df.index[-5:], "run"] = [f"single{i}" for i in range(5)]
    report = diagnose(df, GapQuestion(candidates=CANDIDATES, **ARGS))
    assert report.n_dropped_short_groups == 5 and report.transfer["units"] == 3
    report.to_dict()


def test_decorrelation_length_of_an_ar1_residual():
    rng = np.random.default_rng(0)
    phi = 0.9
    e = np.zeros(20000)
    for k in range(1, e.size):
        e[k] = phi * e[k - 1] + rng.normal()
    # The autocorrelation phi**h first falls below 1/e at h = ceil(1 / -ln(phi)) = 10.
    assert decorrelation_length(e, np.zeros(e.size, int)) in (9, 10, 11)


def test_every_summary_is_at_most_two_sentences_and_sixty_words(air):
    _, report = air
    assert len(report.summary.split()) <= 60 and report.summary.count(". ") <= 1
    assert load_schema()["properties"]["transfer"]["required"]
