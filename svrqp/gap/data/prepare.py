"""Check and arrange the input table of a gap diagnosis.

Handling of awkward input (documented contract):

* unknown columns, a non-numeric target / feature / prediction / candidate / order column,
  a candidate that is also the target or the prediction, and a ``train`` query that selects
  no row or every row raise :class:`~svrqp.exceptions.ProblemError` naming the cause;
* rows with a missing or non-finite value in any column the diagnosis uses are dropped and
  counted (``n_dropped`` in the JSON) — except that candidates are needed on the real rows
  only: a sensor fitted after the model was built leaves them empty on the train rows, and
  nothing but the verdict's refit of the model (then not given) reads them there;
* a group with fewer than :data:`MIN_GROUP_ROWS` rows cannot carry a rate or a filtered
  signal; its rows are dropped and counted (``n_dropped_short_groups``), and so are the real
  rows of a group with fewer real rows than that (the transforms run on the real rows);
* repeated ``order`` values within a group raise :class:`ProblemError` (a rate would divide
  by zero);
* without ``order`` the row position within the group is the order axis (``"row"``);
  without ``group`` all rows form one group.

Rows are returned sorted by group (in order of first appearance) and by order within a group; a
group whose rows do not come in increasing ``order`` is sorted along it, and named
(``order_sorted`` in the JSON): a stated fallback, since a file may list a run backwards.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError
from svrqp.gap.contract import MIN_GROUP_ROWS, MIN_REAL_ROWS
from svrqp.gap.question import GapQuestion
from svrqp.query import select_rows
from svrqp.table_checks import check_numeric, check_present

ROW_ORDER_NAME = "row"
"""Name of the order axis when no ``order`` column is given: position within the group."""


@dataclass(frozen=True)
class GapData:
    """The rows of a diagnosis, sorted by group and order, as numeric arrays.

    Attributes
    ----------
    target : str
        Name of the measured column.
    y : ndarray, shape (n,)
        Measured target.
    features : list of str
        Model inputs (empty in prediction mode).
    X : ndarray, shape (n, len(features))
        Feature values.
    prediction_name : str or None
        Column holding a simulation's prediction (prediction mode), else None.
    prediction : ndarray, shape (n,) or None
        The prediction column's values in prediction mode.
    candidates : list of str
        Candidate columns.
    C : ndarray, shape (n, len(candidates))
        Candidate values (finite on the real rows; may be NaN on train rows).
    order_name : str
        Name of the order axis (``"row"`` when none was given).
    t : ndarray, shape (n,)
        Order values, strictly increasing within each group.
    group_name : str or None
        Name of the group column.
    groups : ndarray of int, shape (n,)
        Group code per row (0, 1, ... in order of first appearance).
    group_labels : list of str
        Label of each group code.
    is_train : ndarray of bool, shape (n,)
        Rows the model was built on; the others are the *real* rows.
    row_index : ndarray, shape (n,)
        Index labels of the rows in the caller's table.
    n_dropped : int
        Rows dropped for missing or non-finite values.
    n_dropped_short_groups : int
        Rows dropped because their group (or its real
        part) had fewer than :data:`MIN_GROUP_ROWS` rows.
    order_sorted : list of str
        Groups whose rows did not come in increasing order and were sorted along it.
    """

    target: str
    y: np.ndarray
    features: list[str]
    X: np.ndarray
    prediction_name: str | None
    prediction: np.ndarray | None
    candidates: list[str]
    C: np.ndarray
    order_name: str
    t: np.ndarray
    group_name: str | None
    groups: np.ndarray
    group_labels: list[str]
    is_train: np.ndarray
    row_index: np.ndarray
    n_dropped: int
    n_dropped_short_groups: int
    order_sorted: list[str] = field(default_factory=list)
    along: dict[str, np.ndarray] = field(default_factory=dict)
    """Values of the ``local_along`` columns
    (:class:`svrqp.gap.question.GapQuestion`) on the rows."""

    @property
    def is_real(self) -> np.ndarray:
        """Rows where the gap is assessed (not used to build the model)."""
        return ~self.is_train


def _train_mask(df: pd.DataFrame, train: str | np.ndarray | pd.Series) -> np.ndarray:
    """Boolean mask of the train rows from a filter (:mod:`svrqp.query`) or a boolean mask."""
    if isinstance(train, str):
        # A filter language, never pandas' eval (svrqp.query); positions, not index labels.
        return select_rows(df.reset_index(drop=True), train).to_numpy()
    mask = np.asarray(train)
    if mask.dtype != bool or mask.shape != (len(df),):
        raise ProblemError("train: give a pandas query string or a boolean mask with one entry per "
                           "row")
    return mask


def _as_list(names: str | list[str] | tuple[str, ...] | None) -> list[str]:
    if names is None:
        return []
    if isinstance(names, str):
        return [n.strip() for n in names.split(",") if n.strip()]
    # numpy's str_ names print as np.str_('...') in messages; plain str is the same column
    return [str(name) if isinstance(name, str) else name for name in names]


def prepare(df: pd.DataFrame, question: GapQuestion) -> GapData:
    """Validate the question of a diagnosis and arrange its rows.

    Parameters
    ----------
    df : pandas.DataFrame
        The measurements, one row per sample.
    question : GapQuestion
        What is asked (:class:`svrqp.gap.question.GapQuestion`); see the module docstring for
        how missing values, short groups and bad input are handled.

    Returns
    -------
    GapData
    """
    if not isinstance(df, pd.DataFrame):
        raise ProblemError("df: expected a pandas DataFrame")
    features, candidates = _as_list(question.features), _as_list(question.candidates)
    along = _as_list(question.local_along)
    _check_columns(df, question, features, candidates)
    _check_along(df, question, along)
    # Needed on every row; candidates only on the real rows (module docstring).
    every_row = [question.target, *features,
                 *along] + ([question.prediction] if question.prediction else [])
    if question.order is not None:
        every_row.append(question.order)
    is_train = _train_mask(df, question.train)
    keep = _complete_rows(df, every_row, candidates, is_train)
    if question.group is not None:
        keep &= df[question.group].notna().to_numpy()
    table, is_train = df.loc[keep], is_train[keep]
    codes, group_labels, long_enough = _group_codes(table, question.group, is_train)
    table, codes, is_train = table.loc[long_enough], codes[long_enough], is_train[long_enough]
    t_raw = _order_values(table, question.order, codes, len(group_labels))
    order_sorted = _unsorted_groups(codes, t_raw, group_labels)
    sort = np.lexsort((t_raw, codes))
    codes, t_raw, is_train = codes[sort], t_raw[sort], is_train[sort]
    table = table.iloc[sort]
    _check_order(codes, t_raw, group_labels, question)
    _check_counts(is_train, question, features)

    prediction = question.prediction
    return GapData(
        target=question.target,
        y=table[question.target].astype(float).to_numpy(),
        features=features,
        X=table[features].astype(float).to_numpy().reshape(len(table), len(features)),
        prediction_name=prediction,
        prediction=table[prediction].astype(float).to_numpy() if prediction else None,
        candidates=candidates,
        C=table[candidates].astype(float).to_numpy(),
        order_name=question.order if question.order is not None else ROW_ORDER_NAME,
        t=t_raw,
        group_name=question.group,
        groups=codes,
        group_labels=group_labels,
        is_train=is_train,
        row_index=table.index.to_numpy(),
        n_dropped=int((~keep).sum()),
        n_dropped_short_groups=int((~long_enough).sum()),
        order_sorted=order_sorted,
        along={name: table[name].astype(float).to_numpy() for name in along},
    )


def _check_along(df: pd.DataFrame, question: GapQuestion, along: list[str]) -> None:
    """Raise :class:`ProblemError` for ``local_along``
    without ``local``, or a missing or non-numeric column."""
    if not along:
        return
    if not question.local:
        raise ProblemError("local_along: windows along a column are a part of the local form; ask "
                           "local=True too")
    if question.order is not None and question.order in along:
        raise ProblemError(f"local_along: {question.order!r} is the order axis, whose windows the "
                           f"local form tries")
    if len(set(along)) != len(along):
        raise ProblemError("local_along: a column is listed twice")
    check_present(df, along, "local_along")
    check_numeric(df, along, "local_along")


def _check_columns(df: pd.DataFrame, question: GapQuestion, features: list[str],
                   candidates: list[str]) -> None:
    """Raise :class:`ProblemError` for a missing,
    misplaced or non-numeric column of the question."""
    target, prediction, order, group = (
        question.target, question.prediction, question.order, question.group,
    )
    if features and prediction is not None:
        raise ProblemError("give either features (a model is fitted) or prediction (a column), not "
                           "both")
    if not features and prediction is None:
        raise ProblemError("give the model's features (at least one column) or a prediction column")
    if not candidates:
        raise ProblemError("candidates: at least one candidate column is required")
    if len(set(candidates)) != len(candidates) or len(set(features)) != len(features):
        raise ProblemError("candidates/features: a column is listed twice")
    check_present(df, [target], "target")
    check_present(df, features, "features")
    check_present(df, candidates, "candidates")
    for name, role in ((prediction, "prediction"), (order, "order"), (group, "group")):
        if name is not None:
            check_present(df, [name], role)
    clash = sorted({target, prediction} & set(candidates) - {None})
    if clash:
        raise ProblemError(f"candidates: {clash} is the target or the prediction, not a candidate")
    if target in features:
        raise ProblemError(f"features: the target {target!r} cannot be a feature")
    if order is not None and order in candidates:
        raise ProblemError(f"candidates: the order column {order!r} cannot be a candidate")
    check_numeric(df, [target], "target")
    check_numeric(df, features, "features")
    check_numeric(df, candidates, "candidates")
    for name, role in ((prediction, "prediction"), (order, "order")):
        if name is not None:
            check_numeric(df, [name], role)


def _complete_rows(df: pd.DataFrame, every_row: list[str], candidates: list[str],
                   is_train: np.ndarray) -> np.ndarray:
    """Rows finite in every column they need (candidates
    on the real rows only); an empty column raises."""
    finite = np.isfinite(df[every_row].astype(float).to_numpy())
    candidate_finite = np.isfinite(df[candidates].astype(float).to_numpy())
    empty = [name for name, any_finite in zip(every_row, finite.any(axis=0), strict=True)
             if not any_finite]
    if empty:
        raise ProblemError(f"column(s) {empty} hold no finite value (every row would be dropped)")
    empty = [name for name, any_finite
             in zip(candidates, candidate_finite[~is_train].any(axis=0), strict=True)
             if not any_finite]
    if empty and not is_train.all():  # with no real row at all, _check_counts says so
        raise ProblemError(f"candidates: {empty} hold no finite value on the real rows (every real "
                           "row would be dropped); a candidate is read on the real rows")
    return finite.all(axis=1) & (is_train | candidate_finite.all(axis=1))


def _group_codes(table: pd.DataFrame, group: str | None,
                 is_train: np.ndarray) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Group code of each kept row (0, 1, … in order of first appearance), the labels, and the rows
    whose group (and, for a real row, the group's real part) has :data:`MIN_GROUP_ROWS` rows."""
    if group is not None:
        codes, uniques = pd.factorize(table[group].astype(str), sort=False)
    else:
        codes, uniques = np.zeros(len(table), dtype=int), pd.Index(["all"])
    counts = np.bincount(codes, minlength=len(uniques))
    real_counts = np.bincount(codes[~is_train], minlength=len(uniques))
    # Transforms run on each group's real rows alone, so its real part needs the rows as well.
    long_enough = (counts[codes] >= MIN_GROUP_ROWS) & (
        is_train | (real_counts[codes] >= MIN_GROUP_ROWS)
    )
    kept_groups = np.unique(codes[long_enough])
    remap = np.full(len(uniques), -1)
    remap[kept_groups] = np.arange(kept_groups.size)
    return remap[codes], [str(uniques[g]) for g in kept_groups], long_enough


def _order_values(table: pd.DataFrame, order: str | None, codes: np.ndarray,
                  n_groups: int) -> np.ndarray:
    """The order axis of each row: the ``order`` column, or the row position within its group."""
    if order is not None:
        return table[order].astype(float).to_numpy()
    t_raw = np.zeros(len(table))
    for g in range(n_groups):
        rows = codes == g
        t_raw[rows] = np.arange(rows.sum(), dtype=float)
    return t_raw


def _unsorted_groups(codes: np.ndarray, t_raw: np.ndarray, group_labels: list[str]) -> list[str]:
    """Labels of the groups whose rows, as given, do not come in increasing order."""
    by_group = np.argsort(codes, kind="stable")  # each group's rows in the order given
    c, t = codes[by_group], t_raw[by_group]
    falls = (c[1:] == c[:-1]) & (np.diff(t) < 0)
    return [group_labels[g] for g in np.unique(c[1:][falls])]


def _check_order(codes: np.ndarray, t_raw: np.ndarray, group_labels: list[str],
                 question: GapQuestion) -> None:
    """Raise :class:`ProblemError` for a repeated order value within a group (sorted rows)."""
    repeated = (codes[1:] == codes[:-1]) & (np.diff(t_raw) <= 0)
    if repeated.any():
        label = group_labels[codes[1:][repeated][0]]
        value = t_raw[1:][repeated][0]
        hint = ("; if each run restarts the order axis, name the run column with group (--group)"
                if question.group is None else "; each row of a group needs its own order value")
        raise ProblemError(f"order: repeated value {value:g} of {question.order!r} within group "
                           f"{label!r}{hint}")


def _check_counts(is_train: np.ndarray, question: GapQuestion, features: list[str]) -> None:
    """Raise :class:`ProblemError` unless both train and enough real rows are left."""
    n_train = int(is_train.sum())
    if n_train == 0:
        raise ProblemError(f"train: the query {question.train!r} selects no row (after dropping "
                           f"incomplete rows)")
    if n_train == is_train.size:
        raise ProblemError(f"train: the query {question.train!r} selects every row; no real rows "
                           f"are left to assess")
    n_real = is_train.size - n_train
    if n_real < MIN_REAL_ROWS:
        raise ProblemError(f"train: only {n_real} real (non-train) rows; at least {MIN_REAL_ROWS} "
                           f"are needed")
    if features and n_train < len(features) + 2:
        raise ProblemError(f"train: {n_train} train rows are too few for {len(features)} features")
