"""Helpers shared by the subcommands: reading tables, splitting column lists, the model factory."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import pandas as pd

from svrqp.estimators.kernel import DUAL_IPM, LSSVR, SOLVERS, EpsilonSVR
from svrqp.exceptions import BackendNotAvailableError, ProblemError
from svrqp.estimators.linear import LinearLS, PolynomialLS, RecursiveLS
from svrqp.solvers.auto import AUTO, SMO_CROSSOVER
from svrqp.table_checks import check_numeric, check_present

#: The model kinds ``svrqp fit`` and ``svrqp export`` build with :func:`make_estimator`.
MODELS = ("svr", "lssvr", "mlr", "poly", "rls")

#: ``--help`` of every ``--solver`` option that picks how an ε-SVR is solved.
SOLVER_HELP = (f"svr: '{AUTO}' (the default: the fastest certified exact path), '{SMO_CROSSOVER}' (loose SMO, "
               f"then the exact crossover), '{DUAL_IPM}' (svrqp's interior point with exact crossover) or a QP "
               f"backend: {', '.join(name for name in SOLVERS if name not in (AUTO, SMO_CROSSOVER, DUAL_IPM))}.")


def read_table(path: str | Path) -> pd.DataFrame:
    """Read a CSV or Parquet file into a DataFrame, with a clear error when it is missing."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"input file not found: {path}")
    if path.suffix.lower() in {".parquet", ".pq"}:
        try:
            table = pd.read_parquet(path)
        except ImportError as err:
            raise BackendNotAvailableError(
                f"reading {path.name} needs a Parquet engine: pip install 'svrqp[parquet]' (pyarrow)") from err
        _refuse_repeated_names(path, [str(name) for name in table.columns])
        return table
    try:
        table = pd.read_csv(path)
    except pd.errors.EmptyDataError as err:
        raise ProblemError(f"{path.name}: the file is empty (no header row)") from err
    _refuse_repeated_names(path, _csv_header(path))
    header = str(table.columns[0])
    separator = next((sep for sep in (";", "\t", "|") if sep in header), None)
    if table.shape[1] == 1 and separator is not None:
        # Guessing the separator (and then the decimal mark) could misread numbers: say it instead.
        raise ProblemError(f"{path.name} reads as one column {header!r}: it seems separated by {separator!r}; "
                           "save it comma-separated, with '.' as the decimal mark")
    return table


def _csv_header(path: Path) -> list[str]:
    """The column names of a CSV file as written (pandas renames a repeated ``T1_C`` to ``T1_C.1``)."""
    with path.open(newline="", encoding="utf-8-sig", errors="replace") as handle:
        return next(csv.reader(handle), [])


def _refuse_repeated_names(path: Path, names: list[str]) -> None:
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ProblemError(f"{path.name}: column name(s) {repeated} appear more than once in the header; "
                           "give every column its own name")


def split_columns(text: str | None, table: pd.DataFrame, option: str, numeric: bool = False) -> list[str]:
    """Split ``"a,b,c"`` into column names and check that each is in ``table`` (and numeric, if asked)."""
    if text is None or not text.strip():
        return []
    names = [name.strip() for name in text.split(",") if name.strip()]
    check_present(table, names, option)
    if numeric:
        check_numeric(table, names, option)
    return names


def parse_gamma(text: str) -> str | float:
    """``"scale"``, ``"auto"`` or a positive number."""
    if text in ("scale", "auto"):
        return text
    try:
        value = float(text)
    except ValueError:
        raise ProblemError(f"--gamma must be 'scale', 'auto' or a positive number, got {text!r}") from None
    if not value > 0:
        raise ProblemError(f"--gamma must be positive, got {text!r}")
    return value


def make_estimator(model: str, *, C: float, epsilon: float, gamma: str | float, degree: int,
                   forgetting: float, solver: str) -> Any:
    """The unfitted estimator of kind ``model`` (one of :data:`MODELS`)."""
    if model == "svr":
        if solver not in SOLVERS:
            raise ProblemError(f"--solver must be one of {', '.join(SOLVERS)}, got {solver!r}")
        return EpsilonSVR(C=C, epsilon=epsilon, gamma=gamma, solver=solver)
    if model == "lssvr":
        return LSSVR(C=C, gamma=gamma)
    if model == "mlr":
        return LinearLS()
    if model == "poly":
        return PolynomialLS(degree=degree)
    if model == "rls":
        return RecursiveLS(forgetting=forgetting)
    raise ProblemError(f"--model must be one of {MODELS}, got {model!r}")
