"""Helpers shared by the subcommands: option help texts, reading tables, the model factory.

This module is imported when a command's ``--help`` is shown, so it loads no heavy library at
import time: pandas and the table checks are imported by the functions that read a table, the
estimators by :func:`make_estimator` (through :mod:`svrqp.registry`).
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from svrqp import registry
from svrqp.exceptions import BackendNotAvailableError, ProblemError
from svrqp.solvers.auto import AUTO, SMO_CROSSOVER
from svrqp.solvers.qp_backends import BACKENDS

if TYPE_CHECKING:
    import pandas as pd

#: The model names ``svrqp fit`` and ``svrqp export`` build with :func:`make_estimator`.
MODELS = registry.names()
#: svrqp's interior point with exact crossover, a value of ``EpsilonSVR(solver=...)``.
DUAL_IPM = "dual_ipm"

#: What each model name means, for every ``--model`` help text.
MODEL_WORDS = {"mlr": "multiple linear regression", "svr": "ε-SVR", "lssvr": "LS-SVR",
               "poly": "polynomial (one input)", "rls": "recursive least squares"}


def _choices(name: str, names: Sequence[str]) -> type[Enum]:
    """A string enum of ``names``: what Typer shows and checks as a choice list."""
    return Enum(name, [(model, model) for model in names], type=str)  # type: ignore[return-value]


#: The ``--model`` choices of ``svrqp fit`` (every model), ``svrqp tune`` (the tunable ones) and
#: ``svrqp gap`` (the baselines it can fit), all from :mod:`svrqp.registry`.
FitModel = _choices("FitModel", registry.names())
TunableModel = _choices("TunableModel", registry.tunable())
BaselineModel = _choices("BaselineModel", registry.baselines())


def model_option(choices: type[Enum], default: str | None, extra_help: str = "") -> Any:
    """The ``--model`` option of a command, one spelling for every command.

    A wrong name is refused with the list of ``choices``; each name's meaning is in the help.
    """
    words = "; ".join(f"{model.value}: {MODEL_WORDS.get(model.value, model.value)}"
                      for model in choices)
    return typer.Option(None if default is None else choices(default), "--model",
                        help=f"{words}.{' ' + extra_help if extra_help else ''}")


#: ``--help`` of every ``--solver`` option that picks how an ε-SVR is solved.
SOLVER_HELP = (f"svr: '{AUTO}' (the default: the fastest certified exact path), '{SMO_CROSSOVER}' "
               f"(loose SMO, then the exact crossover), '{DUAL_IPM}' (svrqp's interior point with "
               f"exact crossover) or a QP backend: {', '.join(BACKENDS)}.")
#: ``--help`` of ``--coverage``, ``--group`` and ``--interval`` (:mod:`svrqp.cli._guard`).
COVERAGE_HELP = ("Calibrate a conformal prediction interval of this coverage (e.g. 0.9) and record "
                 "the training domain (svrqp.Guarded); default: no interval.")
GROUP_HELP = ("With --coverage: column naming the run/batch/cycle of each row; calibration folds "
              "hold out whole groups (rows within a run are not exchangeable).")
INTERVAL_HELP = (
    "With --coverage: absolute or normalized (normalised: wider where the errors are larger)."
)


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


def parse_gamma(text: str) -> str | float:
    """``"scale"``, ``"auto"`` or a positive number."""
    if text in ("scale", "auto"):
        return text
    try:
        value = float(text)
    except ValueError:
        raise ProblemError(
            f"--gamma must be 'scale', 'auto' or a positive number, got {text!r}"
        ) from None
    if not value > 0:
        raise ProblemError(f"--gamma must be positive, got {text!r}")
    return value


def make_estimator(model: str, *, C: float, epsilon: float, gamma: str | float, degree: int,
                   forgetting: float, solver: str) -> Any:
    """The unfitted estimator called ``model`` in
    :mod:`svrqp.registry`, with the options it takes."""
    spec = registry.spec(model, "--model")
    if "solver" in spec.parameters:
        from svrqp.estimators.kernel import SOLVERS

        if solver not in SOLVERS:
            raise ProblemError(f"--solver must be one of {', '.join(SOLVERS)}, got {solver!r}")
    return spec.make(C=C, epsilon=epsilon, gamma=gamma, degree=degree, forgetting=forgetting,
                     solver=solver)


def select_train_rows(table: pd.DataFrame, query: str | None) -> pd.Series:
    """Boolean mask of the rows ``query`` selects (all rows when it is ``None``)."""
    import pandas as pd

    from svrqp.query import QueryError, select_rows

    if query is None:
        return pd.Series(True, index=table.index)
    try:
        mask = select_rows(table, query)  # a filter language, never pandas' eval
    except QueryError as err:
        raise QueryError(f"--train: {err}") from None
    if not mask.any():
        raise ProblemError(f"--train: query {query!r} selects no rows")
    return mask
