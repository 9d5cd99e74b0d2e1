r"""Steps 2 and 3: is there a gap beyond chance (the gate), and where does the error concentrate?

**The gate.** Is there a gap beyond chance? Tests on a residual before any cause is named.

Excess error
    The mean squared residual on the real rows, :math:`s_r^2`, against the out-of-sample
    mean squared residual on the train rows, :math:`s_t^2` (the error to expect where
    nothing is missing, :mod:`svrqp.gap.model`). Under "no gap" their ratio is
    F-distributed; because the rows are autocorrelated, each sample counts with its
    effective size (Bartlett's AR(1) correction)

    .. math::

        F = \frac{s_r^2}{s_t^2},\qquad
        n_{\mathrm{eff}} = n\,\frac{1-\rho_1}{1+\rho_1},\qquad
        p = P\bigl(F_{n_{\mathrm{eff},r},\,n_{\mathrm{eff},t}} \ge F\bigr),

    with :math:`\rho_1` the lag-1 autocorrelation of each residual
    (:func:`svrqp.gap.data.runs.lag1_autocorrelation`).

Excess over noise
    The same F test against the noise variance estimated from successive differences within
    groups (von Neumann's mean square successive difference),

    .. math::

        \hat\sigma^2 = \frac{\sum_g \sum_k (r_{g,k} - r_{g,k-1})^2}{2 \sum_g (n_g - 1)},

    which a smooth error leaves almost untouched (coloured noise makes :math:`\hat\sigma^2`
    too small, so this test errs towards "gap"; the surrogate tests of the attribution remain
    the guard against naming a cause).

Decision
    The gate is one-sided. A gap exists only when the real rows fit worse than the train rows
    (:math:`s_r > s_t`, both out of sample: the model never saw the real rows, and the train
    reference is cross-validated, or in prediction mode the prediction's own train-row error)
    and that excess is beyond chance against the train reference or the noise level
    (:math:`\min(p_\mathrm{excess}, p_\mathrm{noise}) < \alpha`). Real rows that fit no worse
    than the train rows are no gap, whatever the noise test says; no cause is then named.

Whiteness
    The Ljung–Box statistic of the real-row residual, pooled over groups,

    .. math::

        Q = n(n+2)\sum_{h=1}^{H}\frac{\hat\rho_h^2}{n-h} \sim \chi^2_H ,

    the residual test of system identification (Ljung, *System Identification*, §16.6).
    Measurement noise is often coloured, so a non-white residual alone is reported but does
    not decide anything; the decision on causes rests on the surrogate tests of
    :mod:`svrqp.gap.within.surrogate_tests`, which keep the residual's autocorrelation.

**Where** (:func:`localise`). Where along the order axis
(or a candidate column) the real-row error concentrates.

For a column :math:`u` (the ``--order`` axis first, then each candidate) an *error tree* — a
regression tree of the squared residual :math:`e^2` on :math:`u` alone, with at most
:data:`MAX_LEAVES` leaves of at least :data:`MIN_LEAF_FRACTION` of the rows — cuts the range of
:math:`u` into intervals. The tree is fitted on one half of the real rows and *scored on the
other half*: an interval counts as a region of concentrated error only if the held-out rows in
it have a mean squared error above the held-out overall mean,

.. math::

    \kappa_I = \frac{\overline{e^2}\big|_{I,\ \mathrm{held\
    out}}}{\overline{e^2}\big|_{\mathrm{held\ out}}} > 1 .

The halves: with enough groups to hold whole ones out, the even cross-validation folds (whole
groups) fit and the odd ones score — a region must recur in other runs. With fewer groups the
order axis is cut into :data:`ORDER_BLOCKS` blocks of equal row counts, pooled over the
groups, and alternate blocks fit and score: every stretch of the axis is then scored on the rows
of *every* group. (Blocks interleaved within each group would score a stretch on the rows of
one group and fit it on another's, so a stretch where only one of two runs goes wrong could
never count.) An interval without any held-out row joins an enriched neighbour when its fitting
rows are above their own mean. Adjacent enriched intervals are merged. Each region is reported
with its bounds (the smallest and largest value of :math:`u` among the real rows inside), its
RMSE, its share of the total
squared error :math:`\sum_{i\in I} e_i^2 / \sum_i e_i^2` and its number of rows, all over
every real row. When no interval stands out on the order axis the error is spread evenly and
the whole range is reported as one region. Candidate-column regions are reported only when
:math:`\kappa_I \ge` :data:`CANDIDATE_MIN_ENRICHMENT`.

Within one run
    Pooled over the runs, a stretch where one run goes wrong is weighed against every run's
    error: a start-up transient of a few minutes in a summer run disappears next to an autumn
    run that drifts for hours (S0). With two or more real runs the order axis of each run with
    at least :data:`MIN_RUN_ROWS` rows therefore gets its own error tree, with :math:`\kappa_I`
    taken against that run's own held-out mean. Its halves are alternate blocks of
    consecutive rows of the run, each at most half the smallest leaf long, so that an interval
    as short as a leaf still holds held-out rows. Such a region is reported (with its run in
    ``group``, its share of the run's squared error in ``share_of_run``, and ``share`` still of
    every real row's) when :math:`\kappa_I \ge` :data:`RUN_MIN_ENRICHMENT` and most of its
    rows are not already inside a pooled region.

    This describes a run; it does not test it. With interleaved halves the held-out rows sit
    next to fitting rows, so on an autocorrelated residual a run's error that wanders high
    somewhere is reported there — which is where that run's error is, not evidence that the
    stretch is special. Measured on pure AR(1) noise, 250 rows per run: a region is reported in
    about 5 % of runs for white noise, 15 % at :math:`\varphi = 0.5` and 70–90 % at
    :math:`\varphi \ge 0.9`. Tests of "this stretch of one run is special" against surrogates
    were tried and found either liberal at strong autocorrelation or blind to S0's transient.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy import stats
from sklearn.tree import DecisionTreeRegressor

from svrqp.gap.contract import ALPHA
from svrqp.gap.data import group_slices, holds_out_groups, lag1_autocorrelation
from svrqp.gap.results.records import GateResult, Region
from svrqp.metrics import rms

LJUNG_BOX_LAGS = 20
"""Largest lag :math:`H` of the Ljung–Box statistic (fewer for short groups)."""



def effective_size(residual: np.ndarray, groups: np.ndarray) -> float:
    """Effective number of independent rows of an AR(1)-like residual."""
    rho = lag1_autocorrelation(residual, groups)
    return max(2.0, len(residual) * (1 - rho) / (1 + rho))


def excess_error_pvalue(real: np.ndarray, real_groups: np.ndarray, train: np.ndarray,
                        train_groups: np.ndarray) -> float:
    """One-sided p-value that the real-row mean square exceeds the train reference's."""
    ms_real, ms_train = float(np.mean(real**2)), float(np.mean(train**2))
    if ms_train <= 0:
        return 0.0 if ms_real > 0 else 1.0
    ratio = ms_real / ms_train
    return float(stats.f.sf(ratio, effective_size(real, real_groups),
                            effective_size(train, train_groups)))


def successive_difference_variance(residual: np.ndarray, groups: np.ndarray) -> float:
    """Noise variance from successive differences within groups (see module docstring)."""
    num = den = 0.0
    for rows in group_slices(groups):
        d = np.diff(residual[rows])
        num += float(d @ d)
        den += 2.0 * d.size
    return num / den if den > 0 else 0.0


def noise_pvalue(real: np.ndarray, real_groups: np.ndarray) -> float:
    """One-sided p-value that the real-row mean square exceeds the noise level."""
    noise = successive_difference_variance(real, real_groups)
    ms_real = float(np.mean(real**2))
    if noise <= 0:
        return 0.0 if ms_real > 0 else 1.0
    n_pairs = len(real) - len(group_slices(real_groups))
    return float(stats.f.sf(ms_real / noise, effective_size(real, real_groups), max(n_pairs, 1)))


def ljung_box_pvalue(residual: np.ndarray, groups: np.ndarray, lags: int = LJUNG_BOX_LAGS) -> float:
    """Ljung–Box p-value with autocorrelations pooled over groups (each group demeaned)."""
    slices = group_slices(groups)
    shortest = min(s.stop - s.start for s in slices)
    H = int(min(lags, max(1, shortest // 4)))
    num = np.zeros(H)
    den = 0.0
    for rows in slices:
        e = residual[rows] - residual[rows].mean()
        den += float(e @ e)
        for h in range(1, H + 1):
            num[h - 1] += float(e[h:] @ e[:-h])
    if den <= 0:
        return 1.0
    n = len(residual)
    rho = num / den
    Q = n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, H + 1)))
    return float(stats.chi2.sf(Q, H))


def gate(real: np.ndarray, real_groups: np.ndarray, train: np.ndarray,
         train_groups: np.ndarray) -> GateResult:
    """Run the excess-error and whiteness tests on a real-row residual.

    Parameters
    ----------
    real : ndarray
        Residual on the real rows (before or after adding an effect).
    real_groups : ndarray of int
        Group code per real row (contiguous groups).
    train : ndarray
        Out-of-sample reference residual on the train rows.
    train_groups : ndarray of int
        Group code per train row.

    Returns
    -------
    GateResult
    """
    train_rmse = float(rms(train))
    real_rmse = float(rms(real))
    return GateResult(
        train_rmse=train_rmse,
        real_rmse=real_rmse,
        ratio=real_rmse / train_rmse
        if train_rmse > 0
        else (float("inf") if real_rmse > 0 else float("nan")),
        p_excess=excess_error_pvalue(real, real_groups, train, train_groups),
        noise_rmse=float(np.sqrt(successive_difference_variance(real, real_groups))),
        p_noise=noise_pvalue(real, real_groups),
        p_white=ljung_box_pvalue(real, real_groups),
        rho1=lag1_autocorrelation(real, real_groups),
    )


def gap_detected(result: GateResult) -> bool:
    """Whether the gate finds a gap beyond chance (see "Decision" in the module docstring)."""
    return result.real_rmse > result.train_rmse and min(result.p_excess, result.p_noise) < ALPHA


def refit_closes(refit_real: np.ndarray, groups: np.ndarray) -> bool:
    """Whether the refit alone, same inputs, leaves nothing but noise on the real rows.

    The contract (``docs/gap.md``): a candidate is the gap's cause only if it explains what more
    data does not. When the leave-one-unit-out refit leaves a real-row error no larger than the
    noise level beyond chance (the gate's excess-over-noise test, :func:`noise_pvalue`), the gap
    was the model used outside its data; a candidate that still trims the remaining noise
    improves the model everywhere, it is not the gap's cause. (The train rows are no reference
    here: a withheld effect that acts on them as well inflates their error as much as the
    refit's.)
    """
    return noise_pvalue(refit_real, groups) >= ALPHA


# -- where the error concentrates ------------------------------------------------------

MAX_LEAVES = 6
"""Most intervals an error tree cuts a column into."""

MIN_LEAF_FRACTION = 0.05
"""Smallest interval, as a fraction of the rows the tree is fitted on."""

CANDIDATE_MIN_ENRICHMENT = 1.5
"""Least held-out enrichment for a region of a candidate column to be reported."""

RUN_MIN_ENRICHMENT = 2.0
"""Least held-out enrichment, against its run's own
mean, for a region within one run to be reported."""

MAX_CANDIDATE_REGIONS = 5
"""Most candidate-column regions reported (highest share first)."""

MIN_RUN_ROWS = 40
"""Fewest rows a run needs for an error tree of its own (two smallest leaves per half)."""

MAX_RUN_REGIONS = 5
"""Most regions within single runs reported (highest share first)."""

ORDER_BLOCKS = 20
"""With few groups, alternate blocks of this many along the order axis fit and score the trees."""



def _smallest_leaf(n_fit: int) -> int:
    """Fewest rows an error tree fitted on ``n_fit`` rows may put in a leaf."""
    return max(2, int(np.ceil(MIN_LEAF_FRACTION * n_fit)))


def _intervals(u: np.ndarray, e2: np.ndarray) -> np.ndarray:
    """Cut points of an error tree of ``e2`` on ``u`` (sorted split thresholds)."""
    tree = DecisionTreeRegressor(max_leaf_nodes=MAX_LEAVES, min_samples_leaf=_smallest_leaf(len(u)),
                                 random_state=0)
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
    unscored = np.zeros(cuts.size + 1, dtype=bool)
    for c in range(cuts.size + 1):
        rows = held & (cell == c)
        unscored[c] = not rows.any()
        enriched[c] = rows.any() and overall > 0 and e2[rows].mean() > overall
    # An interval with no held-out row (short, inside one fitting block) joins an enriched
    # neighbour when its own fitting rows are above their mean too: it cannot be scored alone.
    fit_mean = e2[fit_rows].mean()
    high_on_fit = [unscored[c] and e2[fit_rows & (cell == c)].mean() > fit_mean
                   for c in range(cuts.size + 1)]
    for c in np.flatnonzero(high_on_fit):
        enriched[c] = (c > 0 and enriched[c - 1]) or (c < cuts.size and enriched[c + 1])
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


def _region(column: str, u: np.ndarray, e2: np.ndarray, inside: np.ndarray, held: np.ndarray,
            overall: float) -> Region:
    total = e2.sum()
    held_inside = inside & held
    return Region(
        column=column,
        low=float(u[inside].min()),
        high=float(u[inside].max()),
        rmse=float(np.sqrt(e2[inside].mean())),
        share=float(e2[inside].sum() / total) if total > 0 else 0.0,
        n=int(inside.sum()),
        enrichment=float(e2[held_inside].mean() / overall) if held_inside.any() and overall > 0
        else float("nan"),
    )


def region_of(t: np.ndarray, e: np.ndarray, region: dict) -> Region:
    """The ``where`` entry of a local verdict's stretch ``region`` (``{"column", "low", "high"}``)
    of the order axis or a ``local_along`` column, on the real
    rows (that column's values ``t``, residual ``e``).

    Its enrichment is in sample (the stretch was chosen
    by the transfer refits, not by an error tree).
    """
    inside = (t >= region["low"]) & (t <= region["high"])
    e2 = e**2
    return _region(region["column"], t, e2, inside, np.ones(t.size, dtype=bool), float(e2.mean()))


def fit_half(order: np.ndarray, folds: list[np.ndarray], groups: np.ndarray) -> np.ndarray:
    """Rows the error trees are fitted on (the others score them); see the module docstring."""
    fit_rows = np.zeros(order.size, dtype=bool)
    if holds_out_groups(groups):
        for f, test in enumerate(folds):
            fit_rows[test] = f % 2 == 0
        return fit_rows
    edges = np.quantile(order, np.linspace(0.0, 1.0, ORDER_BLOCKS + 1)[1:-1])
    block = np.searchsorted(edges, order, side="right")  # equal order values share a block
    return block % 2 == 0


def within_run_fit_half(n: int) -> np.ndarray:
    """Rows of one run (sorted along the order) its error tree is fitted on; the others score it.

    Alternate blocks of consecutive rows, each at most half as long as the smallest leaf the
    tree may cut, so that every interval a tree can report holds held-out rows.
    """
    block = max(1, _smallest_leaf(n / 2) // 2)
    return (np.arange(n) // block) % 2 == 0


def run_regions(order_name: str, order: np.ndarray, e: np.ndarray, groups: np.ndarray,
                labels: list[str], pooled: list[Region]) -> list[Region]:
    """Regions of concentrated error within single runs that the pooled regions leave out.

    Parameters
    ----------
    order_name : str
        Name of the order axis.
    order, e : ndarray, shape (n,)
        Order values and residual of the real rows.
    groups : ndarray of int, shape (n,)
        Group code per real row (an index into ``labels``).
    labels : list of str
        Run label of every group code.
    pooled : list of Region
        Enriched order-axis regions pooled over the runs.

    Returns
    -------
    list of Region
        By decreasing share, at most :data:`MAX_RUN_REGIONS` (none with fewer than two runs).
    """
    codes = np.unique(groups)
    if codes.size < 2:
        return []
    total = float(np.sum(e**2))
    found = []
    for code in codes:
        rows = np.flatnonzero(groups == code)
        if rows.size < MIN_RUN_ROWS:
            continue
        rows = rows[np.argsort(order[rows], kind="stable")]
        u, e_run = order[rows], e[rows]
        covered = np.zeros(u.size, dtype=bool)
        for p in pooled:
            covered |= (u >= p.low) & (u <= p.high)
        for region in regions_on(order_name, u, e_run, within_run_fit_half(rows.size)):
            inside = (u >= region.low) & (u <= region.high)
            if region.enrichment < RUN_MIN_ENRICHMENT or covered[inside].mean() > 0.5:
                continue
            share = float(np.sum(e_run[inside] ** 2) / total) if total > 0 else 0.0
            found.append(replace(region, share=share, group=labels[code],
                                 share_of_run=region.share))
    found.sort(key=lambda r: -r.share)
    return found[:MAX_RUN_REGIONS]


def localise(
    e: np.ndarray,
    order_name: str,
    order: np.ndarray,
    candidates: dict[str, np.ndarray],
    folds: list[np.ndarray],
    groups: np.ndarray,
    labels: list[str] | None = None,
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
        Blocked cross-validation folds of the real rows.
    groups : ndarray of int
        Group code per real row (:func:`fit_half` says which rows fit and which score).
    labels : list of str, optional
        Run label of every group code (default: the codes themselves), for regions within one run.

    Returns
    -------
    list of Region
        Order-axis regions pooled over the runs by decreasing share (the whole range when none
        stands out), then regions within single runs (:func:`run_regions`), then candidate
        regions with enrichment of at least :data:`CANDIDATE_MIN_ENRICHMENT`, each by
        decreasing share.
    """
    fit_rows = fit_half(order, folds, groups)
    pooled = sorted(regions_on(order_name, order, e, fit_rows), key=lambda r: -r.share)
    on_order = pooled or [_region(order_name, order, e**2, np.ones(len(e), dtype=bool), ~fit_rows,
                                  float(np.mean(e[~fit_rows] ** 2)))]
    labels = labels if labels is not None else [str(code) for code in range(int(groups.max()) + 1)]
    within_runs = run_regions(order_name, order, e, groups, labels, pooled)
    on_candidates = [
        region
        for name, u in candidates.items()
        for region in regions_on(name, u, e, fit_rows)
        if region.enrichment >= CANDIDATE_MIN_ENRICHMENT
    ]
    on_candidates.sort(key=lambda r: -r.share)
    return on_order + within_runs + on_candidates[:MAX_CANDIDATE_REGIONS]
