"""Input checks and row handling of the gap diagnosis (svrqp.gap.data.prepare, through diagnose)."""

import numpy as np
import pandas as pd
import pytest
from support.gap_problems import CANDIDATES, air_lag_problem, null_problem

from svrqp.exceptions import ProblemError
from svrqp.gap import GapQuestion, diagnose
from svrqp.gap.data.prepare import prepare

ARGS = {"target": "error_um", "train": "run == 'r0'", "features": ["spindle_C"], "candidates": CANDIDATES,
            "order": "time_min", "group": "run"}


@pytest.fixture(scope="module")
def table():
    """The closed-form null problem (four runs of 240 rows)."""
    return null_problem()


def test_rows_are_sorted_by_group_and_order(table):
    shuffled = table.sample(frac=1.0, random_state=0)
    data = prepare(shuffled, GapQuestion(**ARGS))
    assert data.group_labels == list(dict.fromkeys(shuffled["run"]))
    for g in range(4):
        assert np.all(np.diff(data.t[data.groups == g]) > 0)
    np.testing.assert_array_equal(data.y, shuffled.loc[data.row_index, "error_um"].to_numpy())
    assert set(data.order_sorted) == set(data.group_labels)  # every shuffled run was sorted, and said so
    assert prepare(table, GapQuestion(**ARGS)).order_sorted == []


def _diagnosed(table, **question):
    """The schema-valid JSON document of a diagnosis."""
    import json

    import jsonschema

    from svrqp.gap import load_schema

    document = json.loads(diagnose(table, GapQuestion(**ARGS | question)).to_json())
    jsonschema.validate(document, load_schema())
    return document


def test_a_run_listed_backwards_is_sorted_and_named(table):
    backwards = pd.concat([table[table.run != "r2"], table[table.run == "r2"].iloc[::-1]], ignore_index=True)
    document = _diagnosed(backwards)
    assert document["order_sorted"] == ["r2"]
    assert _diagnosed(table)["order_sorted"] == []


def test_a_candidate_of_one_value_is_named_not_tested(table):
    document = _diagnosed(table.assign(k_C=5.0), candidates=[*CANDIDATES, "k_C"])
    cause = next(c for c in document["causes"] if c["column"] == "k_C")
    assert cause["note"].startswith("constant on the real rows (5)") and not cause["significant"]


def test_a_record_of_one_run_is_cut_into_blocks():
    one = air_lag_problem().query("run == 'r1'")
    document = _diagnosed(one, train=f"time_min < {one.time_min.median()}")
    assert document["blocks"] is not None and document["blocks"]["n"] >= 5
    assert "held-out blocks" in document["summary"]


@pytest.mark.parametrize("option, value, message", [
    ("target", "missing_um", "target: unknown column"),
    ("features", ["spindle_C", "bogus"], "features: unknown column"),
    ("candidates", ["air_C", "bogus"], "candidates: unknown column"),
    ("order", "bogus", "order: unknown column"),
    ("group", "bogus", "group: unknown column"),
])
def test_unknown_columns_are_named(table, option, value, message):
    with pytest.raises(ProblemError, match=message):
        prepare(table, GapQuestion(**ARGS | {option: value}))


def test_train_query_selecting_no_rows(table):
    with pytest.raises(ProblemError, match="selects no row"):
        prepare(table, GapQuestion(**ARGS | {"train": "run == 'nope'"}))


def test_train_query_selecting_all_rows(table):
    with pytest.raises(ProblemError, match="selects every row"):
        prepare(table, GapQuestion(**ARGS | {"train": "time_min >= 0"}))


def test_bad_train_query(table):
    with pytest.raises(ProblemError, match="cannot evaluate query"):
        prepare(table, GapQuestion(**ARGS | {"train": "run ==="}))


def test_non_numeric_candidate(table):
    labelled = table.assign(label=np.where(table["time_min"] > 100, "hot", "cold"))
    with pytest.raises(ProblemError, match=r"candidates: column\(s\) \['label'\] are not numeric"):
        prepare(labelled, GapQuestion(**ARGS | {"candidates": ["air_C", "label"]}))


def test_features_and_prediction_are_exclusive(table):
    with pytest.raises(ProblemError, match="either features"):
        prepare(table, GapQuestion(**ARGS | {"prediction": "air_C"}))
    for nothing in (None, []):
        with pytest.raises(ProblemError, match="give the model's features .* or a prediction column"):
            prepare(table, GapQuestion(**ARGS | {"features": nothing}))


def test_a_column_without_any_finite_value_is_named(table):
    with pytest.raises(ProblemError, match=r"\['nut_C'\] hold no finite value"):
        prepare(table.assign(nut_C=np.nan), GapQuestion(**ARGS))
    with pytest.raises(ProblemError, match=r"column\(s\) \['spindle_C'\] hold no finite value"):
        prepare(table.assign(spindle_C=np.nan), GapQuestion(**ARGS))


def test_a_candidate_recorded_on_the_train_rows_only_is_named(table):
    train_only = table.assign(nut_C=table["nut_C"].where(table["run"] == "r0"))
    with pytest.raises(ProblemError, match=r"candidates: \['nut_C'\] hold no finite value on the real rows"):
        prepare(train_only, GapQuestion(**ARGS))


def test_target_cannot_be_a_candidate(table):
    with pytest.raises(ProblemError, match="target or the prediction"):
        prepare(table, GapQuestion(**ARGS | {"candidates": ["error_um"]}))


def test_rows_with_missing_values_are_dropped_and_counted(table):
    holes = table.copy()
    holes.loc[[300, 400], "air_C"] = np.nan  # a candidate on two real rows
    holes.loc[[5, 600], "error_um"] = [np.nan, np.inf]  # the target on a train and a real row
    holes.loc[17, "spindle_C"] = np.nan  # a feature on a train row
    data = prepare(holes, GapQuestion(**ARGS))
    assert data.n_dropped == 5
    assert len(data.y) == len(table) - 5 and np.isfinite(data.C).all()


def test_candidates_are_needed_on_the_real_rows_only(table):
    """A sensor fitted after the model was built: empty on the train run, kept there as NaN."""
    late = table.copy()
    train = late["run"] == "r0"
    late.loc[train, "air_C"] = np.nan
    late.loc[train & (late["time_min"] < 50), "coolant_C"] = np.nan
    data = prepare(late, GapQuestion(**ARGS))
    assert data.n_dropped == 0 and data.is_train.sum() == train.sum()
    air = data.C[:, data.candidates.index("air_C")]
    assert np.isnan(air[data.is_train]).all() and np.isfinite(data.C[data.is_real]).all()


def test_short_groups_are_dropped_and_counted(table):
    extra = table.iloc[:2].assign(run="tiny")
    data = prepare(pd.concat([table, extra], ignore_index=True), GapQuestion(**ARGS))
    assert data.n_dropped_short_groups == 2
    assert "tiny" not in data.group_labels


def test_a_group_with_too_few_real_rows_loses_them_and_the_diagnosis_runs(table):
    # a train query by time leaves run r1 two real rows: too few for a rate or a filter of their own
    query = "run == 'r0' or (run == 'r1' and time_min < 238)"
    data = prepare(table, GapQuestion(**ARGS | {"train": query}))
    assert data.n_dropped_short_groups == 2
    assert data.is_train[data.groups == data.group_labels.index("r1")].all()
    report = diagnose(table, GapQuestion(**ARGS | {"train": query}))
    assert report.n_dropped_short_groups == 2 and report.n_real == data.is_real.sum()


def test_names_given_as_a_numpy_array_read_as_plain_names(table):
    data = prepare(table, GapQuestion(**ARGS | {"candidates": np.array(["air_C", "nut_C"])}))
    assert data.candidates == ["air_C", "nut_C"] and type(data.candidates[0]) is str
    with pytest.raises(ProblemError, match=r"unknown column\(s\) \['bogus'\]"):
        prepare(table, GapQuestion(**ARGS | {"candidates": np.array(["air_C", "bogus"])}))


def test_repeated_order_within_a_group(table):
    repeated = table.copy()
    repeated.loc[3, "time_min"] = repeated.loc[2, "time_min"]
    with pytest.raises(ProblemError, match="repeated value .* within group 'r0'; each row of a group needs"):
        prepare(repeated, GapQuestion(**ARGS))


def test_runs_restarting_the_order_axis_without_a_group_get_a_hint(table):
    with pytest.raises(ProblemError, match="within group 'all'; if each run restarts the order axis, name the run"):
        prepare(table, GapQuestion(**ARGS | {"group": None}))


def test_without_order_the_row_position_is_used(table):
    data = prepare(table, GapQuestion(**ARGS | {"order": None}))
    assert data.order_name == "row"
    np.testing.assert_array_equal(data.t[data.groups == 0], np.arange(240.0))


def test_a_model_feature_may_be_a_candidate(table):
    data = prepare(table, GapQuestion(**ARGS | {"candidates": ["spindle_C", "air_C"]}))
    assert data.candidates == ["spindle_C", "air_C"]


def test_train_query_selects_by_position_when_index_labels_repeat(table):
    # pd.concat of per-run tables repeats index labels; a label-based mask would take every
    # row whose label also occurs in run r0 (here: all of them) as a train row.
    repeated = pd.concat([run.reset_index(drop=True) for _, run in table.groupby("run", sort=False)])
    assert repeated.index.duplicated().any()
    data = prepare(repeated, GapQuestion(**ARGS))
    assert data.is_train.sum() == (table["run"] == "r0").sum()
    assert {data.group_labels[g] for g in data.groups[data.is_train]} == {"r0"}


def test_a_datetime_order_gets_a_hint_to_give_elapsed_time(table):
    stamped = table.assign(stamp=pd.Timestamp("2026-01-05") + pd.to_timedelta(table["time_min"], unit="min"))
    with pytest.raises(ProblemError, match=r"order: .*'stamp'.*dates or durations.*time_min"):
        prepare(stamped, GapQuestion(**ARGS | {"order": "stamp"}))
