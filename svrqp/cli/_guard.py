"""``--coverage``, ``--group`` and ``--interval`` of
``svrqp fit`` and ``svrqp export``: wrap in Guarded.

The options' help texts are in :mod:`svrqp.cli._common` (this module loads scikit-learn).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import pandas as pd
from rich.table import Table
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from svrqp.exceptions import ExtrapolationWarning, ProblemError
from svrqp.guard import Guarded
from svrqp.guard.conformal import METHODS
from svrqp.table_checks import check_present


def guarded_or_plain(model: Any, coverage: float | None, group: str | None, method: str, *,
                     standardize: bool = False) -> Any:
    """``model`` as the commands fit it: after a ``StandardScaler`` with ``--standardize``, wrapped
    in :class:`Guarded` when ``--coverage`` is given."""
    if standardize:
        model = make_pipeline(StandardScaler(), model)
    if coverage is None:
        if group is not None:
            raise ProblemError("--group only applies with --coverage")
        return model
    if method not in METHODS:
        raise ProblemError(f"--interval must be one of {', '.join(METHODS)}, got {method!r}")
    return Guarded(model, coverage=coverage, method=method)


def group_labels(table: pd.DataFrame, group: str | None) -> pd.Series | None:
    """The ``--group`` column (checked present), or None."""
    if group is None:
        return None
    check_present(table, [group], "--group")
    return table[group]


def fit_guarded(model: Any, X: pd.DataFrame, y: pd.Series, groups: pd.Series | None) -> Any:
    """Fit ``model``, passing ``groups`` when it is a Guarded model."""
    if isinstance(model, Guarded):
        return model.fit(X, y, groups=None if groups is None else groups.to_numpy())
    return model.fit(X, y)


def describe_interval(interval: dict[str, Any]) -> str:
    """One line from an ``interval`` section: coverage,
    method, quantile and how it was calibrated."""
    calibration = interval["calibration"]
    groups = "" if calibration["groups"] is None else f" over {len(calibration['groups'])} groups"
    return (f"interval: {interval['coverage']:g} conformal ({interval['method']}), quantile q = "
            f"{interval['quantile']:.4g}; calibrated on out-of-fold residuals, "
            f"{calibration['folds']}{groups}")


def interval_table(model: Guarded, row_sets: list[tuple[str, pd.DataFrame, pd.Series]],
                   unit: str) -> Table:
    """Per row set: share of measurements inside the
    interval, mean width, share outside the domain."""
    table = Table(title=f"interval ({model.coverage:g} nominal) and domain",
                  caption="train rows are in-sample (optimistic); other rows test the interval")
    for column in ("rows", "n", "inside interval", f"mean width ({unit or 'target units'})",
                   "outside domain"):
        table.add_column(column, justify="left" if column == "rows" else "right")
    for label, X, y in row_sets:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ExtrapolationWarning)  # reported as a share below
            interval = model.predict_interval(X)
        y = y.to_numpy(dtype=float)
        inside = np.mean((y >= interval[:, 0]) & (y <= interval[:, 1]))
        outside = model.check_domain(X)["outside"].mean()
        table.add_row(label, str(len(y)), f"{inside:.3f}",
                      f"{np.mean(interval[:, 1] - interval[:, 0]):.4g}", f"{outside:.3f}")
    return table
