"""Reading a command's input table (CSV or Parquet) and naming its columns, with errors that say
what is wrong: the reader of ``svrqp fit``, ``gap``, ``simulate``/``plot`` and ``fleet``.

pandas and the table checks are imported by the functions, so importing this module stays quick
(a command's ``--help`` imports it).
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TYPE_CHECKING

from svrqp.exceptions import BackendNotAvailableError, ProblemError

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["read_table", "split_columns"]


def read_table(path: str | Path) -> pd.DataFrame:
    """Read a CSV or Parquet file into a DataFrame, with a clear error when it is missing."""
    import pandas as pd

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"input file not found: {path}")
    if path.suffix.lower() in {".parquet", ".pq"}:
        try:
            table = pd.read_parquet(path)
        except ImportError as err:
            raise BackendNotAvailableError(
                f"reading {path.name} needs a Parquet engine: pip install 'svrqp[parquet]' "
                f"(pyarrow)") from err
        _refuse_repeated_names(path, [str(name) for name in table.columns])
        return table
    names, has_rows = _csv_header(path)
    _refuse_repeated_names(path, names)
    if names and not has_rows:
        # Checked before pandas reads it: pandas builds one
        # empty column per name (minutes for 1e5 names).
        raise ProblemError(f"{path.name}: the file has a header of {len(names)} column(s) but no "
                           f"data rows")
    try:
        table = pd.read_csv(path)
    except pd.errors.EmptyDataError as err:
        raise ProblemError(f"{path.name}: the file is empty (no header row)") from err
    header = str(table.columns[0])
    separator = next((sep for sep in (";", "\t", "|") if sep in header), None)
    if table.shape[1] == 1 and separator is not None:
        # Guessing the separator (and then the decimal mark) could misread numbers: say it instead.
        raise ProblemError(f"{path.name} reads as one column {header!r}: it seems separated by "
                           f"{separator!r}; save it comma-separated, with '.' as the decimal mark")
    return table


def _csv_header(path: Path) -> tuple[list[str], bool]:
    """The column names of a CSV file as written (pandas renames a repeated ``T1_C`` to ``T1_C.1``),
    and whether a non-blank row follows the header."""
    with path.open(newline="", encoding="utf-8-sig", errors="replace") as handle:
        rows = csv.reader(handle)
        names = next(rows, [])
        has_rows = any(any(cell.strip() for cell in row) for row in rows)
    return names, has_rows


def _refuse_repeated_names(path: Path, names: list[str]) -> None:
    from svrqp.table_checks import check_unique_names

    check_unique_names(names, path.name)


def split_columns(text: str | None, table: pd.DataFrame, option: str,
                  numeric: bool = False) -> list[str]:
    """Split ``"a,b,c"`` into column names and check
    that each is in ``table`` (and numeric, if asked)."""
    if text is None or not text.strip():
        return []
    from svrqp.table_checks import check_numeric, check_present

    names = [name.strip() for name in text.split(",") if name.strip()]
    check_present(table, names, option)
    if numeric:
        check_numeric(table, names, option)
    return names
