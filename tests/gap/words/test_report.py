"""The gap report: schema-valid JSON, no silent overwrite, HTML and Markdown (svrqp.gap.words.report)."""

import dataclasses
import json
import math
import os
import re
import stat

import jsonschema
import numpy as np
import pytest
from support.gap_problems import CANDIDATES, air_lag_problem, null_problem

from svrqp.exceptions import SvrqpError
from svrqp.gap import GapQuestion, diagnose, load_schema
from svrqp.gap.results.document import _finite
from svrqp.gap.words.report import _num, share_text

ARGS = {"target": "error_um", "train": "run == 'r0'", "features": ["spindle_C"], "candidates": CANDIDATES,
            "order": "time_min", "group": "run"}


@pytest.fixture(scope="module")
def report():
    """Diagnosis of the air-lag problem (a verdict with a lag and a time constant)."""
    return diagnose(air_lag_problem(), GapQuestion(**ARGS))


@pytest.fixture(scope="module")
def null_report():
    """Diagnosis of the null problem (no verdict)."""
    return diagnose(null_problem(), GapQuestion(**ARGS))


@pytest.mark.parametrize("which", ["report", "null_report"])
def test_json_is_valid_against_the_shipped_schema(which, request):
    document = json.loads(request.getfixturevalue(which).to_json())
    jsonschema.validate(document, load_schema())
    assert document["schema"] == "svrqp.gap/2"
    for key in ("target", "gap", "where", "causes", "verdict"):
        assert key in document


def test_contract_fields_of_a_verdict(report):
    document = json.loads(report.to_json())
    verdict = document["verdict"]
    assert verdict["column"] == "air_C" and verdict["transform"] == "lag" and verdict["tau"] > 0
    top = document["causes"][0]
    assert top["shrink"] == pytest.approx(1 - top["rmse_after"] / top["rmse_before"])
    assert document["gap"]["real_rmse"] == pytest.approx(top["rmse_before"])
    assert all(0 <= region["share"] <= 1 for region in document["where"])


def test_null_verdict_is_a_null_column(null_report):
    verdict = json.loads(null_report.to_json())["verdict"]
    assert verdict["column"] is None and verdict["shrink"] is None


def test_schema_rejects_a_named_verdict_without_a_transform():
    document = {"schema": "svrqp.gap/2", "target": "e", "gap": {"train_rmse": 1, "real_rmse": 2}, "where": [],
                "causes": [], "verdict": {"column": "T9"}}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(document, load_schema())


def test_non_finite_numbers_become_null():
    assert _finite({"a": float("nan"), "b": [1.0, float("inf")], "c": (2, 3)}) == {"a": None, "b": [1.0, None], "c": [2, 3]}


def test_a_report_that_breaks_the_schema_is_never_written(report, tmp_path):
    broken = dataclasses.replace(report, n_rows=-1)  # not a count
    with pytest.raises(SvrqpError, match="schema"):
        broken.write_json(tmp_path / "out.json")
    assert not (tmp_path / "out.json").exists()


def test_write_json_refuses_to_overwrite_without_force(report, tmp_path):
    path = tmp_path / "gap.json"
    report.write_json(path)
    with pytest.raises(FileExistsError, match="force"):
        report.write_json(path)
    report.write_json(path, force=True)
    assert json.loads(path.read_text())["verdict"]["column"] == "air_C"


def test_written_files_get_the_usual_permissions_and_leave_no_temporary_file(report, tmp_path):
    old_mask = os.umask(0o022)
    try:
        path = report.write_json(tmp_path / "gap.json")
    finally:
        os.umask(old_mask)
    assert stat.S_IMODE(path.stat().st_mode) == 0o644
    assert [p.name for p in tmp_path.iterdir()] == ["gap.json"]


def test_html_is_self_contained_with_two_figures(report, tmp_path):
    path = report.to_html(tmp_path / "gap.html")
    text = path.read_text(encoding="utf-8")
    assert text.count("data:image/png;base64,") == 2  # gap plot and before/after plot
    assert report.summary.split(";")[0] in text.replace("&#x27;", "'")
    assert "<table>" in text


def test_markdown_writes_figures_beside_it(report, tmp_path):
    text = report.to_markdown(tmp_path / "gap.md")
    assert (tmp_path / "gap_gap.png").stat().st_size > 1000
    assert (tmp_path / "gap_before_after.png").exists()
    assert "| rank | column | transform |" in text
    with pytest.raises(FileExistsError):
        report.to_markdown(tmp_path / "gap.md")


def test_summary_is_at_most_two_short_sentences_with_the_transfer_shrink(report, null_report):
    for text in (report.summary, null_report.summary):
        assert text.count(". ") <= 1 and text.endswith(".") and len(text.split()) <= 60
        assert "cross-validated on the train rows" in text
    assert "air_C" in report.summary and f"shrinks it by {report.verdict.shrink:.0%}" in report.summary
    assert math.isfinite(report.runtime_s) and report.runtime_s > 0


@pytest.mark.parametrize("how", ["prediction equals the target", "constant target"])
def test_a_model_without_error_gives_a_valid_report_and_no_verdict(how):
    table = null_problem()
    if how == "constant target":
        args, table = ARGS, table.assign(error_um=1.5)
    else:
        args = {k: v for k, v in ARGS.items() if k != "features"} | {"prediction": "prediction_um"}
        table = table.assign(prediction_um=table["error_um"])
    result = diagnose(table, GapQuestion(**args))
    jsonschema.validate(json.loads(result.to_json()), load_schema())
    assert result.verdict.column is None and result.causes == []
    assert "reproduces the real rows exactly" in result.verdict.reason
    assert "reproduces error_um exactly" in result.summary and result.to_dict()["gap"]["ratio"] is None


def test_base_shrink_equals_scikit_learn_cross_validation_of_the_base(report):
    """The base alone, re-derived with scikit-learn: least squares on the base columns, predicted on
    each blocked fold by cross_val_predict over the same folds (PredefinedSplit). The engine adds a
    ridge of 1e-8 per training row (svrqp.gap.data.discrepancy.RIDGE), worth 1e-7 of the RMSE here; with
    it set to zero the two agree to 1e-13."""
    from sklearn.linear_model import LinearRegression
    from sklearn.model_selection import PredefinedSplit, cross_val_predict

    from svrqp.gap.data.prepare import prepare
    from svrqp.gap.data.runs import blocked_folds
    from svrqp.gap.model import fit_baseline
    from svrqp.gap.model import base_design

    data = prepare(air_lag_problem(), GapQuestion(**ARGS))
    baseline = fit_baseline(data, "mlr")
    r, groups = baseline.residual[data.is_real], data.groups[data.is_real]
    fold_of = np.empty(r.size, dtype=int)
    for k, test in enumerate(blocked_folds(groups)):
        fold_of[test] = k
    predicted = cross_val_predict(LinearRegression(fit_intercept=False), base_design(data, baseline), r,
                                  cv=PredefinedSplit(fold_of))
    rmse_after = np.sqrt(np.mean((r - predicted) ** 2))
    assert report.base.rmse_after == pytest.approx(rmse_after, rel=1e-6)
    assert report.base.shrink == pytest.approx(1 - rmse_after / np.sqrt(np.mean(r**2)), rel=1e-6)
    assert "base alone" in report.to_markdown() and report.to_dict()["base"]["shrink"] == report.base.shrink
    before = np.sqrt(np.mean(r**2))
    within = diagnose(air_lag_problem(), GapQuestion(**ARGS), within_evidence=True)
    assert within.base == report.base
    for cause in within.causes:  # the per-run recalibration numbers, fitted on the real rows themselves
        within_rmse = (1 - cause.within_shrink) * before
        assert cause.shrink_beyond_base == pytest.approx(1 - within_rmse / rmse_after, rel=1e-6)


@pytest.mark.parametrize("name, unit, label", [
    ("error_um", "μm", "error (μm)"),
    ("Fehler_µm", "μm", "Fehler (μm)"),  # a MICRO SIGN in the name reads as μ
    ("spindle_box_C", "°C", "spindle box (°C)"),
    ("time_min", "min", "time (min)"),
    ("deviation", None, "deviation (units of the column)"),
    ("row", "rows", "row within group (count)"),
], ids=["um", "micro sign", "C", "min", "no unit", "row"])
def test_units_are_read_off_column_names(name, unit, label):
    from svrqp.gap.words.figures import axis_label
    from svrqp.units import unit_of

    assert unit_of(name) == unit and axis_label(name) == label


def test_a_target_without_a_unit_is_summarised_without_one():
    table = air_lag_problem().rename(columns={"error_um": "deviation"})
    result = diagnose(table, GapQuestion(**ARGS | {"target": "deviation"}))
    assert "units of the column" not in result.summary and "RMS against" in result.summary


def test_a_small_share_is_not_printed_as_zero():
    """A region within one run can hold well under 1 % of every run's squared error."""
    assert share_text(0.0033) == "0.3%" and share_text(0.81) == "81%"
    assert share_text(0.0) == "0%" and share_text(1.0) == "100%"


def test_large_numbers_are_printed_without_an_exponent():
    """Order bounds of a long record (2636 min) read badly as 2.64e+03."""
    assert _num(2636.4) == "2636" and _num(-1234.6) == "-1235"
    assert _num(26.614) == "26.6" and _num(26.764, 4) == "26.76" and _num(2.5e6) == "2.5e+06" and _num(None) == "–"
    assert _num(123.44) == "123" and _num(1234.4, 4) == "1234" and _num(12345.6, 4) == "12346"
    assert _num(999.7) == "1000" and _num(0.000123) == "0.000123"  # rounding up to 10**digits, small numbers


def test_the_inputs_table_covers_model_inputs_and_candidates(report, tmp_path):
    header, rows = report.tables()["inputs"]
    expected = report.features + [c for c in report.candidates if c not in report.features]
    assert [row[0] for row in rows] == expected and "beyond the offsets" in header
    assert [row[1] for row in rows] == ["input"] * len(report.features) + ["candidate"] * (len(rows) - len(report.features))
    assert rows[0][2].endswith(" °C")  # spindle_C: the unit read off the column name
    assert "## Model inputs" in report.to_markdown()
    assert "<h2>Model inputs</h2>" in report.to_html(tmp_path / "gap.html").read_text(encoding="utf-8")
    df = air_lag_problem()
    df["prediction_um"] = 2.0 * df["spindle_C"]
    args = {k: v for k, v in ARGS.items() if k != "features"}
    in_prediction_mode = diagnose(df, GapQuestion(prediction="prediction_um", **args))
    assert {row[1] for row in in_prediction_mode.tables()["inputs"][1]} == {"candidate"}


@pytest.mark.parametrize("which, sections, figures", [
    ("report", ["Gap", "Where", "Causes", "Model inputs", "Verdict"], ["measured, model and residual", "before and after"]),
    ("null_report", ["Gap", "Where", "Causes", "Model inputs", "Verdict"], ["measured, model and residual"]),
])
def test_markdown_and_html_hold_the_same_sections_and_figures_in_order(which, sections, figures, request, tmp_path):
    report = request.getfixturevalue(which)
    markdown = report.to_markdown()
    page = report.to_html(tmp_path / "gap.html").read_text(encoding="utf-8")
    assert re.findall(r"^## (.+)$", markdown, flags=re.M) == sections == re.findall(r"<h2>(.+?)</h2>", page)
    assert re.findall(r"!\[(.+?)\]", markdown) == figures == re.findall(r'<img alt="(.+?)"', page)
    assert markdown.index(report.verdict.reason) > markdown.index("## Verdict")
