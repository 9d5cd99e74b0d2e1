"""What a gap diagnosis is asked: :class:`GapQuestion`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd


@dataclass(frozen=True)
class GapQuestion:
    """The question put to :func:`svrqp.gap.diagnose`: which model, on which rows, which suspects.

    Parameters
    ----------
    target : str
        Measured column (e.g. ``"error_um"``).
    train : str or boolean mask
        Filter selecting the rows the model was built on (e.g. ``"batch == 'x1'"``,
        :mod:`svrqp.query`) or a boolean mask with one entry per row; the other rows are the
        *real* rows where the gap is assessed.
    candidates : str or list of str
        Measured columns that may carry the unmodelled effect (a model feature may be a
        candidate: then only its ``rate`` and ``lag`` are tested). A string is split at commas.
    features : str or list of str, optional
        Model inputs; a baseline of kind ``model`` is fitted on the train rows. Exclusive
        with ``prediction``.
    prediction : str, optional
        Column holding a simulation's prediction (nothing is fitted).
    order : str, optional
        Time (min) or position (mm) column; rates and filters run along it.
    group : str, optional
        Run/batch column; transforms restart and cross-validation is blocked per group.
    model : {"mlr", "svr", "lssvr"}
        Baseline model family (features mode; :mod:`svrqp.gap.model`).
    local : bool
        Also refit every candidate in the ``local`` form, acting in one window of the
        ``order`` axis only (:mod:`svrqp.gap.transfer.windows`), and name that window with a
        verdict. Off by default: offered to every diagnosis it changes some borderline verdicts of
        global effects (docs/gap.md, "Localised effects").
    local_along : str or list of str, optional
        With ``local``, columns along which the ``local`` form also tries windows: the rows where
        the column is above, or below, one of its deciles (a sensor that matters only above a
        spindle speed). A string is split at commas.
    """

    target: str
    train: str | np.ndarray | pd.Series
    candidates: str | list[str]
    features: str | list[str] | None = None
    prediction: str | None = None
    order: str | None = None
    group: str | None = None
    model: str = "mlr"
    local: bool = False
    local_along: str | list[str] | None = None
