"""Second hostile campaign (issue #39) on the ``--train`` filter and the table checks: each test is
a named reproducer that failed before the fix."""

from __future__ import annotations


import pandas as pd
import pytest

from svrqp.cli._common import read_table
from svrqp.exceptions import ProblemError
from svrqp.query import QueryError, select_rows
from svrqp.table_checks import check_unique_names


def test_backtick_placeholder_does_not_clash_with_a_real_column():
    """#1: ```T 7``` became ``svrqp_column_0``, silently swapping in the real column of that name."""
    table = pd.DataFrame({"T 7": [5, 6, 7], "svrqp_column_0": [30, 20, 30]})
    mask = select_rows(table, "`T 7` > 5.5 and svrqp_column_0 < 25")
    assert mask.tolist() == [False, True, False]


def test_full_width_name_is_not_normalised_onto_another_column():
    """#2: Python's parser NFKC-normalises ``ｔ`` to ``t``; the filter must use the column typed."""
    table = pd.DataFrame({"t": [0, 2, 0], "ｔ": [2, 0, 2]})
    assert select_rows(table, "ｔ > 1").tolist() == [True, False, True]
    assert select_rows(table, "t > 1").tolist() == [False, True, False]
    with pytest.raises(QueryError, match="ｔ"):
        select_rows(pd.DataFrame({"t": [1, 2]}), "ｔ > 1")


def test_backticks_inside_a_triple_quoted_string_are_left_alone():
    """#3: ``'''it's `T 7`'''`` had its backticks rewritten, so the literal never matched."""
    table = pd.DataFrame({"b": ["it's `T 7`", "x", "y"]})
    assert select_rows(table, "b == '''it's `T 7`'''").tolist() == [True, False, False]
    assert select_rows(table, 'b == "it\\\'s `T 7`"').tolist() == [True, False, False]


def test_huge_integer_literal_is_a_query_error():
    """#7: a 400-digit literal against a float column raised OverflowError (a CLI traceback)."""
    table = pd.DataFrame({"x": [1.0, 2.0]})
    with pytest.raises(QueryError, match="out of range"):
        select_rows(table, "x < " + "9" * 400)


@pytest.mark.parametrize("columns", [40_000, 100_000])
def test_repeated_names_of_a_huge_header_are_found(columns):
    """#16: the repeated-name check counted every name in the whole list (quadratic: minutes)."""
    names = [f"c{i}" for i in range(columns)] + ["c7"]
    with pytest.raises(ProblemError, match="c7"):
        check_unique_names(names, "table")


@pytest.mark.parametrize("repeat", [False, True])
def test_header_only_csv_of_100000_columns_is_refused(tmp_path, repeat):
    """#16: a header-only CSV of 40,000 columns took 35 s (100,000: minutes) before the error:
    the quadratic repeat check, then pandas building an empty column per name."""
    names = [f"c{i}" for i in range(100_000)] + (["c7"] if repeat else [])
    path = tmp_path / "wide.csv"
    path.write_text(",".join(names) + "\n")
    with pytest.raises(ProblemError, match="appear more than once" if repeat else "no data rows"):
        read_table(path)
