r"""Where along the order axis (or a candidate column) the real-row error concentrates.

For a column :math:`u` (the ``--order`` axis first, then each candidate) an *error tree* — a
regression tree of the squared residual :math:`e^2` on :math:`u` alone, with at most
:data:`MAX_LEAVES` leaves of at least :data:`MIN_LEAF_FRACTION` of the rows — cuts the range of
:math:`u` into intervals. The tree is fitted on one half of the real rows (the even
cross-validation folds, so whole groups or blocks) and *scored on the other half*: an
interval counts as a region of concentrated error only if the held-out rows in it have a mean
squared error above the held-out overall mean,

.. math::

    \kappa_I = \frac{\overline{e^2}\big|_{I,\ \mathrm{held\ out}}}{\overline{e^2}\big|_{\mathrm{held\ out}}} > 1 .

Adjacent such intervals are merged. Each region is reported with its bounds (the smallest and
largest value of :math:`u` among the real rows inside), its RMSE, its share of the total
squared error :math:`\sum_{i\in I} e_i^2 / \sum_i e_i^2` and its number of rows, all over
every real row. When no interval stands out on the order axis the error is spread evenly and
the whole range is reported as one region. Candidate-column regions are reported only when
:math:`\kappa_I \ge` :data:`CANDIDATE_MIN_ENRICHMENT`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.tree import DecisionTreeRegressor

MAX_LEAVES = 6
"""Most intervals an error tree cuts a column into."""

MIN_LEAF_FRACTION = 0.05
"""Smallest interval, as a fraction of the rows the tree is fitted on."""

CANDIDATE_MIN_ENRICHMENT = 1.5
"""Least held-out enrichment for a region of a candidate column to be reported."""

MAX_CANDIDATE_REGIONS = 5
"""Most candidate-column regions reported (highest share first)."""


@dataclass(frozen=True)
class Region:
    """An interval of one column where the squared error concentrates.

    Attributes
    ----------
    column : str
        Column the interval is on.
    low, high : float
        Smallest and largest value of the column among the real rows in the region.
    rmse : float
        RMSE of the residual in the region.
    share : float
        Region's fraction of the total squared error.
    n : int
        Number of real rows in the region.
    enrichment : float
        Held-out mean squared error in the region over the held-out overall mean.
    """

    column: str
    low: float
    high: float
    rmse: float
    share: float
    n: int
    enrichment: float


def _intervals(u: np.ndarray, e2: np.ndarray) -> np.ndarray:
    """Cut points of an error tree of ``e2`` on ``u`` (sorted split thresholds)."""
    leaf = max(2, int(np.ceil(MIN_LEAF_FRACTION * len(u))))
    tree = DecisionTreeRegressor(max_leaf_nodes=MAX_LEAVES, min_samples_leaf=leaf, random_state=0)
    tree.fit(u[:, None], e2)
    is_split = tree.tree_.children_left >= 0
    return np.sort(tree.tree_.threshold[is_split])


def regions_on(column: str, u: np.ndarray, e: np.ndarray, fit_rows: np.ndarray) -> list[Region]:
    """Regions of concentrated squared error along one column.

    Parameters
    ----------
    column : str
        Name of the column.
    u : ndarray, shape (n,)
        Its values on the real rows.
    e : ndarray, shape (n,)
        Residual on the real rows.
    fit_rows : ndarray of bool, shape (n,)
        Rows the tree is fitted on; the others score it.

    Returns
    -------
    list of Region
        Merged enriched intervals (possibly none), in order along ``u``.
    """
    e2 = e**2
    held = ~fit_rows
    cuts = _intervals(u[fit_rows], e2[fit_rows])
    cell = np.searchsorted(cuts, u, side="left")  # interval index of every row
    overall = e2[held].mean()
    enriched = np.zeros(cuts.size + 1, dtype=bool)
    for c in range(cuts.size + 1):
        rows = held & (cell == c)
        enriched[c] = rows.any() and overall > 0 and e2[rows].mean() > overall
    regions = []
    c = 0
    while c <= cuts.size:
        if not enriched[c]:
            c += 1
            continue
        stop = c
        while stop + 1 <= cuts.size and enriched[stop + 1]:
            stop += 1
        inside = (cell >= c) & (cell <= stop)
        regions.append(_region(column, u, e2, inside, held, overall))
        c = stop + 1
    return regions


def _region(column: str, u: np.ndarray, e2: np.ndarray, inside: np.ndarray, held: np.ndarray, overall: float) -> Region:
    total = e2.sum()
    held_inside = inside & held
    return Region(
        column=column,
        low=float(u[inside].min()),
        high=float(u[inside].max()),
        rmse=float(np.sqrt(e2[inside].mean())),
        share=float(e2[inside].sum() / total) if total > 0 else 0.0,
        n=int(inside.sum()),
        enrichment=float(e2[held_inside].mean() / overall) if held_inside.any() and overall > 0 else float("nan"),
    )


def localise(
    e: np.ndarray,
    order_name: str,
    order: np.ndarray,
    candidates: dict[str, np.ndarray],
    folds: list[np.ndarray],
) -> list[Region]:
    """Ranked regions of concentrated real-row error: order axis first, then candidates.

    Parameters
    ----------
    e : ndarray, shape (n,)
        Residual on the real rows.
    order_name : str
        Name of the order axis.
    order : ndarray, shape (n,)
        Order values of the real rows.
    candidates : dict
        Candidate name → values on the real rows.
    folds : list of ndarray
        Blocked cross-validation folds of the real rows; even folds fit the trees, odd folds
        score them.

    Returns
    -------
    list of Region
        Order-axis regions by decreasing share (the whole range when none stands out), then
        candidate regions with enrichment of at least :data:`CANDIDATE_MIN_ENRICHMENT`, by
        decreasing share.
    """
    fit_rows = np.zeros(len(e), dtype=bool)
    for f, test in enumerate(folds):
        fit_rows[test] = f % 2 == 0
    on_order = sorted(regions_on(order_name, order, e, fit_rows), key=lambda r: -r.share)
    if not on_order:
        everything = np.ones(len(e), dtype=bool)
        on_order = [_region(order_name, order, e**2, everything, ~fit_rows, float(np.mean(e[~fit_rows] ** 2)))]
    on_candidates = [
        region
        for name, u in candidates.items()
        for region in regions_on(name, u, e, fit_rows)
        if region.enrichment >= CANDIDATE_MIN_ENRICHMENT
    ]
    on_candidates.sort(key=lambda r: -r.share)
    return on_order + on_candidates[:MAX_CANDIDATE_REGIONS]
