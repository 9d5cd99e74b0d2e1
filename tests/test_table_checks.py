"""svrqp.table_checks: the column checks shared by the commands and the gap diagnosis."""

import pandas as pd
import pytest

from svrqp.exceptions import ProblemError
from svrqp.table_checks import check_numeric, check_present

TABLE = pd.DataFrame({
    "error_um": [1.0, 2.0], "run": [0, 1], "on": [True, False], "batch": ["x1", "x2"],
    "stamp": pd.to_datetime(["2026-01-01 08:00", "2026-01-01 08:01"]),
})


def test_numbers_and_booleans_pass():
    check_numeric(TABLE, ["error_um", "run", "on"], "--features")


def test_text_columns_are_named_with_the_option():
    with pytest.raises(ProblemError, match=r"--features: column\(s\) \['batch'\] are not numeric$"):
        check_numeric(TABLE, ["error_um", "batch"], "--features")


def test_dates_get_a_hint_about_elapsed_time():
    with pytest.raises(ProblemError, match=r"\['stamp'\] hold dates or durations: give the elapsed time as a number"):
        check_numeric(TABLE, ["stamp"], "--order")


def test_timestamps_read_from_a_csv_file_as_text_get_the_same_hint(tmp_path):
    path = tmp_path / "t.csv"
    TABLE.to_csv(path, index=False)
    table = pd.read_csv(path)
    assert not pd.api.types.is_datetime64_any_dtype(table["stamp"])  # a CSV file gives timestamps as text
    with pytest.raises(ProblemError, match=r"\['stamp'\] hold dates or durations: give the elapsed time as a number"):
        check_numeric(table, ["stamp"], "--order")
    with pytest.raises(ProblemError, match=r"\['batch'\] are not numeric$"):  # other text: no hint
        check_numeric(table, ["batch"], "--order")


def test_text_that_only_begins_with_timestamps_gets_no_date_hint():
    table = pd.DataFrame({"stamp": ["2026-01-01 08:00"] * 60 + ["later"]})
    with pytest.raises(ProblemError, match=r"\['stamp'\] are not numeric$"):
        check_numeric(table, ["stamp"], "--order")


def test_missing_columns_are_named_with_those_the_table_has():
    check_present(TABLE, ["error_um", "batch"], "--features")
    with pytest.raises(ProblemError, match=r"--candidates: unknown column\(s\) \['T9'\]; available: \['error_um', 'run'"):
        check_present(TABLE, ["error_um", "T9"], "--candidates")
