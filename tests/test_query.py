"""The ``--train`` filter language (svrqp.query): what it selects, checked against plain pandas
masks, and what it refuses before anything runs."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest

from svrqp.cli import main
from svrqp.exceptions import ProblemError
from svrqp.gap import GapQuestion
from svrqp.gap.data.prepare import prepare
from svrqp.query import QueryError, select_rows

HOSTILE = "t < 25 and @pd.io.common.os.system('touch PWNED') == 0"


@pytest.fixture
def table() -> pd.DataFrame:
    return pd.DataFrame({"batch": ["x1", "x2", "x1", "x3"], "t": [10.0, 30.0, 24.0, np.nan],
                         "T 7 [°C]": [1.0, 2.0, 3.0, 4.0], "run": [0, 1, 2, 3]})


@pytest.mark.parametrize("query, expected", [
    ("t < 25", lambda d: d.t < 25),
    ("batch == 'x1' and t > 20", lambda d: (d.batch == "x1") & (d.t > 20)),
    ("batch == 'x2' or run >= 3", lambda d: (d.batch == "x2") | (d.run >= 3)),
    ("20 < t <= 30", lambda d: (d.t > 20) & (d.t <= 30)),
    ("batch in ['x1', 'x3']", lambda d: d.batch.isin(["x1", "x3"])),
    ("batch not in ('x1',)", lambda d: ~d.batch.isin(["x1"])),
    ("not t < 25", lambda d: ~(d.t < 25)),
    ("`T 7 [°C]` >= 2", lambda d: d["T 7 [°C]"] >= 2),
    ("(t < 25) & (batch == 'x1')", lambda d: (d.t < 25) & (d.batch == "x1")),
    ("~(run == 1) | (run == 1)", lambda d: pd.Series(True, index=d.index)),
    ("-run < -1", lambda d: -d.run < -1),
    ("run != -1", lambda d: d.run != -1),
    ("batch == '@x'", lambda d: d.batch == "@x"),
    ("True", lambda d: pd.Series(True, index=d.index)),
])
def test_selects_the_rows_of_the_equivalent_pandas_mask(table, query, expected):
    pd.testing.assert_series_equal(select_rows(table, query), expected(table), check_names=False)


def test_nullable_columns_select_no_row_where_a_value_is_missing():
    table = pd.DataFrame({"run": pd.array([1, None, 3], dtype="Int64"), "ok": pd.array([True, None, False])})
    assert select_rows(table, "run >= 1").tolist() == [True, False, True]
    assert select_rows(table, "ok or run == 3").tolist() == [True, False, True]


@pytest.mark.parametrize("query, forbidden", [
    (HOSTILE, "'@'"),
    ("t.__class__ == 1", "attribute"),
    ("__import__('os') == 1", "function call"),
    ("__builtins__ == 1", "'__'"),
    ("t[0] > 1", "subscript"),
    ("(lambda: 1)() == 1", "function call"),
    ("f'{t}' == 'a'", "f-string"),
    ("t * 2 > 1", "operator '\\*'"),
    ("t ** 2 > 1", "operator '\\*\\*'"),
    ("t is None", "comparison 'is'"),
    ("t in t", "right-hand side of 'in'"),
    ("[x for x in t] == 1", "comprehension"),
    ("t if t else t", "'if ... else'"),
    ("(y := 1) == 1", "':='"),
])
def test_refuses_everything_outside_the_language_naming_the_token(table, query, forbidden):
    with pytest.raises(QueryError, match=f"forbidden.*{forbidden}"):
        select_rows(table, query)


@pytest.mark.parametrize("query, message", [
    ("batch ===", "cannot evaluate"),
    ("x > 1", "unknown column 'x'"),
    ("t", "must give True/False"),
    ("t < 'a'", "cannot evaluate"),
    ("`unclosed > 1", "unclosed backtick"),
    ("-" * 1900 + "1 < t", "nested too deeply"),
    ("t < 1 " * 400, "at most"),
])
def test_malformed_filters_are_library_errors(table, query, message):
    with pytest.raises(ProblemError, match=message):
        select_rows(table, query)


def test_hostile_query_runs_nothing_in_fit(tmp_path, monkeypatch, capsys):
    """The reproducer: ``fit --train "... @pd.io.common.os.system('touch PWNED') ..."`` created the file."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "data.csv"
    pd.DataFrame({"t": np.arange(40.0), "T7_C": np.linspace(20, 30, 40),
                  "error_um": np.linspace(0, 5, 40)}).to_csv(path, index=False)
    with pytest.raises(SystemExit) as exit_info:
        main(["fit", str(path), "--target", "error_um", "--features", "T7_C", "--model", "mlr", "--train", HOSTILE])
    assert exit_info.value.code == 2
    assert "forbidden token '@'" in capsys.readouterr().err
    assert not os.path.exists(tmp_path / "PWNED")


def test_hostile_query_runs_nothing_in_gap(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rng = np.random.default_rng(0)
    frame = pd.DataFrame({"t": np.arange(60.0), "a_C": rng.normal(size=60), "b_C": rng.normal(size=60),
                          "error_um": rng.normal(size=60)})
    with pytest.raises(QueryError, match="forbidden token '@'"):
        prepare(frame, GapQuestion(target="error_um", train=HOSTILE, features="a_C", candidates=["b_C"]))
    assert not os.path.exists(tmp_path / "PWNED")
