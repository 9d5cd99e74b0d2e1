"""Reading the input tables of every subcommand (svrqp.cli._common.read_table): CSV and Parquet."""

import re

import pandas as pd
import pytest

from svrqp import datasets
from svrqp.cli._common import read_table
from svrqp.exceptions import BackendNotAvailableError, ProblemError


@pytest.fixture(scope="module")
def table():
    """The miao2013 data set (simulated; 753 rows, a text column and floats)."""
    return datasets.load("miao2013")


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_written_table_reads_back_unchanged(table, tmp_path, suffix):
    path = tmp_path / f"miao{suffix}"
    if suffix == ".csv":
        table.to_csv(path, index=False)
    else:
        pytest.importorskip("pyarrow")
        table.to_parquet(path, index=False)
    pd.testing.assert_frame_equal(read_table(path), table.reset_index(drop=True), check_exact=False, rtol=1e-12)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="input file not found: .*absent.csv"):
        read_table(tmp_path / "absent.csv")


def test_without_a_parquet_engine_the_extra_is_named(table, tmp_path, monkeypatch):
    path = tmp_path / "miao.parquet"
    path.write_bytes(b"PAR1")

    def no_engine(*args, **kwargs):
        raise ImportError("Unable to find a usable engine; tried using: 'pyarrow', 'fastparquet'.")

    monkeypatch.setattr(pd, "read_parquet", no_engine)
    with pytest.raises(BackendNotAvailableError, match=r"svrqp\[parquet\]"):
        read_table(path)


def test_an_empty_file_is_named(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("")
    with pytest.raises(ProblemError, match="empty.csv: the file is empty"):
        read_table(path)


@pytest.mark.parametrize("separator", [";", "\t"])
def test_a_file_with_another_separator_is_named_not_guessed(table, tmp_path, separator):
    # a European export: semicolons, and often decimal commas that a guessed separator would misread
    path = tmp_path / "semicolons.csv"
    table.head(5).to_csv(path, index=False, sep=separator, decimal=",")
    with pytest.raises(ProblemError, match=f"reads as one column .*separated by {re.escape(repr(separator))}"):
        read_table(path)


def test_a_single_column_file_reads(tmp_path):
    path = tmp_path / "one.csv"
    path.write_text("error_um\n1.5\n2.5\n")
    assert read_table(path)["error_um"].tolist() == [1.5, 2.5]


@pytest.mark.parametrize("header", ["T1_C,T1_C,error_um", "\ufeffT1_C,error_um,T1_C", '"T1_C",T2_C,"T1_C"'])
def test_a_repeated_column_name_is_refused(tmp_path, header):
    """pandas reads a second ``T1_C`` as ``T1_C.1``: a model would silently use the wrong sensor."""
    path = tmp_path / "twice.csv"
    path.write_text(header + "\n1.0,2.0,3.0\n4.0,5.0,6.0\n", encoding="utf-8")
    with pytest.raises(ProblemError, match=re.escape("column name(s) ['T1_C'] appear more than once")):
        read_table(path)


def test_names_that_differ_only_by_pandas_suffix_are_kept(tmp_path):
    path = tmp_path / "distinct.csv"
    path.write_text("T1_C,T1_C.1,error_um\n1.0,2.0,3.0\n", encoding="utf-8")
    assert list(read_table(path).columns) == ["T1_C", "T1_C.1", "error_um"]
