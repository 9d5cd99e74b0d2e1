"""Checks on the columns of a user's table, shared by the commands and the gap diagnosis, and on
the arrays handed to the estimators (numbers, not text; magnitudes float64 can square)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from typing import Any

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError

#: Largest magnitude accepted in X or y: squares and products of two such numbers stay finite in
#: float64 (whose largest value is 1.8e308), which every fit needs (variances, Gram matrices,
#: normal equations, residual sums of squares).
MAX_MAGNITUDE = 1e150


def check_numeric_array(values: Any, name: str) -> None:
    """Raise :class:`ProblemError` when ``values`` holds text (numeric text such as ``"1.0"``
    included) instead of numbers: a unit or a decimal comma must not be guessed.

    Parameters
    ----------
    values : array-like
        What the caller passed as X or y.
    name : str
        Its name in the message (``"X"``, ``"y"``).
    """
    array = np.asarray(values)
    text = array.dtype.kind in "USa" or (
        array.dtype == object and any(isinstance(value, str | bytes) for value in array.ravel()))
    if text:
        raise ProblemError(f"{name} holds text, not numbers (dtype {array.dtype}): convert it to "
                           f"numbers first")


def check_magnitude(values: np.ndarray, name: str) -> None:
    """Raise :class:`ProblemError` when a finite value of ``values`` exceeds :data:`MAX_MAGNITUDE`
    in magnitude (non-finite values are left to the finiteness checks, which name them)."""
    finite = np.abs(values[np.isfinite(values)])
    if finite.size and float(finite.max()) > MAX_MAGNITUDE:
        raise ProblemError(f"{name} has values up to {float(finite.max()):.3g} in magnitude; at "
                           f"most {MAX_MAGNITUDE:.0e} is supported (its squares must stay finite "
                           "in float64): express it in a larger unit")


def check_finite_magnitude(values: np.ndarray, name: str) -> None:
    """:func:`check_magnitude` for ``values`` known to be finite (no mask, no copy)."""
    if values.size and float(np.abs(values).max()) > MAX_MAGNITUDE:
        check_magnitude(values, name)


def repeated(names: Iterable[str]) -> list[str]:
    """The names that occur more than once in ``names``, sorted (one pass: a header of 100,000
    columns is checked in milliseconds)."""
    return sorted(name for name, count in Counter(names).items() if count > 1)


def check_unique_names(names: Iterable[str], where: str) -> None:
    """Raise :class:`ProblemError` naming the column names that ``names`` repeats.

    Parameters
    ----------
    names : iterable of str
        Column names as written (a CSV header, a table's columns).
    where : str
        What holds them, for the message (a file name).
    """
    twice = repeated(names)
    if twice:
        shown = twice if len(twice) <= 20 else [*twice[:20], f"... ({len(twice)} in all)"]
        raise ProblemError(f"{where}: column name(s) {shown} appear more than once in the header; "
                           "give every column its own name")


def check_present(table: pd.DataFrame, names: list[str], option: str) -> None:
    """Raise :class:`ProblemError` naming the columns of ``names`` that ``table`` lacks, and listing
    those it has (a typo is then seen at a glance).

    Parameters
    ----------
    table : pandas.DataFrame
        The table that should hold the columns.
    names : list of str
        Column names to look for.
    option : str
        The option or argument that named them, for the message (e.g. ``"--features"``).
    """
    missing = [name for name in names if name not in table.columns]
    if missing:
        raise ProblemError(f"{option}: unknown column(s) {missing}; available: "
                           f"{list(table.columns)}")


def check_numeric(table: pd.DataFrame, names: list[str], option: str) -> None:
    """Raise :class:`ProblemError` naming the columns
    of ``names`` that are neither numeric nor boolean.

    Parameters
    ----------
    table : pandas.DataFrame
        The table holding the columns.
    names : list of str
        Columns to check (present in ``table``).
    option : str
        The option or argument that named them, for the message (e.g. ``"--features"``).
    """
    bad = [n for n in names if not (pd.api.types.is_numeric_dtype(table[n])
                                    or pd.api.types.is_bool_dtype(table[n]))]
    if not bad:
        return
    dates = [n for n in bad if _holds_dates(table[n])]
    hint = (f"; {dates} hold dates or durations: give the elapsed time as a number with its unit "
            "in the name (e.g. time_min)") if dates else ""
    raise ProblemError(f"{option}: column(s) {bad} are not numeric{hint}")


def _holds_dates(column: pd.Series) -> bool:
    """Whether a column holds dates or durations: typed so, or text that reads as ISO 8601
    timestamps (a CSV file gives ``2026-01-01 08:00:00`` as text)."""
    if pd.api.types.is_datetime64_any_dtype(column) or pd.api.types.is_timedelta64_dtype(column):
        return True
    values = column.dropna()
    if values.empty or not all(isinstance(value, str) for value in values):
        return False
    return bool(pd.to_datetime(values, errors="coerce", format="ISO8601").notna().all())
