"""Helpers shared by the subcommands: option help texts, reading tables, the model factory.

This module is imported when a command's ``--help`` is shown, so it loads no heavy library at
import time: pandas and the table checks are imported by the functions that read a table, the
estimators by :func:`make_estimator` (through :mod:`svrqp.registry`).
"""

from __future__ import annotations

from collections.abc import Sequence
from enum import Enum
from typing import TYPE_CHECKING, Any

import typer

from svrqp import registry
from svrqp.exceptions import ProblemError
from svrqp.solvers.auto import AUTO, SMO_CROSSOVER
from svrqp.solvers.qp_backends import BACKENDS
from svrqp.tables import read_table, split_columns  # noqa: F401  (the commands import them here)

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
