r"""The localised transform: a candidate acting in one stretch of the order axis only.

Many unmodelled effects act in one stretch of the ``--order`` axis :math:`t`: a gantry's
synchronisation error while it accelerates, a worn patch of guideway, a start-up transient.
The ``local`` transform of a candidate :math:`x` adds, for one window :math:`W = [t_a, t_b]`,

.. math::

    \mathbb{1}_W(t), \qquad x(t)\,\mathbb{1}_W(t),

an offset and a slope on :math:`x` that act inside the window only (a localised effect that
is affine in the candidate, zero outside). The window is not given: it is one of a small
dictionary (:func:`window_dictionary`) of tiles of the order axis, of widths
:data:`WINDOW_WIDTHS` of its range. Each leave-one-unit-out fit of
:mod:`svrqp.gap.transfer.linear` keeps the window with the smallest squared error on its own rows
(one *variant* per window, as the ``lag`` transform keeps its time constant), so the window
is chosen out of sample, and every surrogate of the transfer test searches the dictionary
again: the test pays for the search.

Judged beyond the window alone
    The window's own offset :math:`\mathbb{1}_W` names no column: a local disturbance that no
    candidate carries gains it with every candidate and every surrogate alike. The nested null of
    the form is therefore the refit with a window's indicator alone (:func:`indicator_columns`,
    the window again chosen inside each fit), and a ``local`` cause must transfer better than it
    by the effect floor (its *gain beyond the window*) to be tested or named; its reported
    ``shrink`` stays the transfer number of candidate × window.

Surrogates that respect what varies where
    Inside a window an effect scales with the candidate's value there, which over a few runs is
    mostly the candidate's level in each run. Rotating the candidate within runs keeps those
    levels with their runs, so a surrogate keeps the very alignment under test (a reading that
    sits at one level per run gains as much rotated as observed; a disturbance whose size per
    run happens to line up with a reading's levels passes). A surrogate of the ``local`` form is
    rotated within runs *and* has its run means exchanged by a random permutation of the runs
    (:func:`svrqp.gap.transfer.surrogates.exchange_run_levels`): under "this candidate carries
    nothing" its within-run phase and which run holds which level are both arbitrary. A candidate
    that holds one level per run is permuted across runs only, as for every transform, unless it
    also moves within runs beyond four times its noise variance
    (:func:`svrqp.gap.transfer.between.moves_beyond_noise`): then its values inside the window
    carry the effect, and it is rotated and exchanged like any other.

What the form costs the other transforms
    The ``local`` form of a candidate that holds one level per run is offered only when a
    permutation of its run levels can reach significance (:func:`permutations_can_reject`):
    with :math:`n` runs the smallest permutation p-value is :math:`1/n!`, and
    Benjamini–Hochberg over :math:`m` columns rejects its first only at :math:`p \le \alpha/m`,
    so the form needs :math:`n! \ge m/\alpha` (five runs for up to six columns at
    :math:`\alpha = 0.05`, six runs for up to 36). An untestable form could only shadow a
    testable cause. It is still refitted, never tested or ranked: when it transfers best, the
    verdict says that the evidence is too thin and names its window
    (:meth:`svrqp.gap.transfer.ranking.TransferRanker.thin_evidence`). Its surrogates come from a
    stream of their own, so offering it leaves the
    Monte-Carlo p-values of the other transforms as they were.

Windows along another column
    An effect can be confined along a column other than the order axis: a sensor that matters
    only above a spindle speed acts wherever in the run the speed is high. With
    ``local_along`` (:class:`svrqp.gap.question.GapQuestion`) the form also tries, for each such
    column :math:`v`, the windows :math:`\{v \ge q\}` and :math:`\{v \le q\}` at its deciles
    (:func:`threshold_dictionary`); everything else — the window chosen inside each fit, the
    search repeated in every surrogate, the window alone as the nested null — is as along the
    order axis, and the verdict's region names that column.

A global cause must transfer outside one stretch
    A disturbance at one place of every run whose size is random from run to run is read by no
    column; over two real runs, a reading that warms up in every run can follow its sizes by
    chance, and its transfer test passes (surrogates rotated within runs do not reproduce the
    coincidence: 15 of 160 simulated thermal records named a column,
    ``benchmarks/results/gap_local_null_size.md``). Such a column transfers where the disturbance
    sits and worse than the same-input refit everywhere else, which no effect acting along the
    whole run does. So before a cause of a global form (not ``local``) is named, the window of
    :func:`window_dictionary` whose offset alone the leave-one-unit-out fits choose most is found
    (where the disturbance sits, if it sits at one place of every run), and a cause whose real-row
    squared error outside that window exceeds the refit's is withheld, its reason saying where it
    transfers (:func:`confined_to`). An effect confined to a stretch is still named in its
    ``local`` form, judged beyond its window alone.

Limits: the window is one interval of the order axis shared by runs (an effect at the
end of passes of unequal length is not one interval). A window is tried only where it is a
stretch of at least two runs' own axis (it lies inside the order range of two groups): on a
record whose clock runs on through the runs (each run its own stretch of time) no window is,
and the ``local`` form is not offered, since a stretch of the clock holds no future run and a
window across the seam of two runs would only carry the end of one into the start of the
next. Nor is a window narrower than :data:`MIN_REGION_ROWS` rows of one unit, or with rows in
fewer than two held-out units; the
``--order`` column is strictly increasing within each group (:mod:`svrqp.gap.data.prepare` refuses
ties and sorts reversed stretches), and gaps only leave some tiles with fewer rows.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from svrqp.gap.data import GapData
from svrqp.gap.results.records import Effect, TransferFit
from svrqp.gap.transfer.linear import LinearTransfer, shrink_of_gain
from svrqp.units import quantity, unit_of

WINDOW_WIDTHS = (0.05, 0.1, 0.2)
"""Widths of the dictionary's tiles, as fractions of the order axis's range."""

SHIFTED_MIN_WIDTH = 0.1
"""Tiles at least this wide are laid a second time, half a tile on: a stretch that starts in the
middle of a tile (a quarter of a run from 50 %) is otherwise split between two tiles that each
hold half of it."""

MIN_REGION_ROWS = 5
"""Fewest rows a window must span along the axis (in the unit where it holds most) to be tried."""

LOCAL_MARGIN = 0.02
"""Shrink by which the ``local`` transform must beat a column's best global transform to stand
for the column (it has the most parameters: two columns and the window's two bounds)."""


def window_dictionary(t: np.ndarray, units: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """The windows tried, as rows ``[low, high]`` of order values (inclusive).

    Tiles of :data:`WINDOW_WIDTHS` of the range of ``t``, those of at least
    :data:`SHIFTED_MIN_WIDTH` also shifted by half a tile; each window's bounds are the smallest
    and largest order value of the rows in its tile, windows holding the same rows are kept
    once, and a window narrower than :data:`MIN_REGION_ROWS` rows (in the unit where it holds
    most), with rows in fewer than two units, or inside the order range of fewer than two
    groups is dropped.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Order value of every row.
    units : ndarray of int, shape (n,)
        Held-out unit of every row.
    groups : ndarray of int, shape (n,)
        Run (group) of every row.

    Returns
    -------
    ndarray, shape (k, 2)
    """
    start, span = float(np.min(t)), float(np.ptp(t))
    out, seen = [], set()
    if span <= 0:
        return np.zeros((0, 2))
    ranges = np.array([(t[groups == g].min(), t[groups == g].max()) for g in np.unique(groups)])
    for width in WINDOW_WIDTHS:
        fractions = np.linspace(0.0, 1.0, round(1 / width) + 1)
        for shift in (0.0, width / 2) if width >= SHIFTED_MIN_WIDTH else (0.0,):
            tiling = fractions + shift
            edges = start + span * tiling[tiling <= 1.0 + 1e-12]
            closed = shift == 0.0  # the last of the unshifted tiles holds the axis's last row
            for i, (a, b) in enumerate(itertools.pairwise(edges)):
                inside = (t >= a) & ((t < b) | (closed and i == edges.size - 2))
                per_unit = np.unique(units[inside], return_counts=True)[1]
                if not per_unit.size or per_unit.max() < MIN_REGION_ROWS or per_unit.size < 2:
                    continue
                bounds = (float(t[inside].min()), float(t[inside].max()))
                shared = np.sum((ranges[:, 0] <= bounds[0]) & (ranges[:, 1] >= bounds[1]))
                if shared >= 2 and bounds not in seen:
                    seen.add(bounds)
                    out.append(bounds)
    return np.array(out).reshape(-1, 2)


THRESHOLD_QUANTILES = np.linspace(0.1, 0.9, 9)
"""Levels of a ``local_along`` column (its deciles) above or below which a window along it holds."""


def threshold_dictionary(v: np.ndarray, units: np.ndarray, groups: np.ndarray) -> np.ndarray:
    r"""The windows tried along a ``local_along`` column
    ``v``, as rows ``[low, high]`` of its values (inclusive).

    An effect confined along a column other than the order axis (a sensor that matters only
    above a spindle speed) acts where the column is above, or below, a level: the rows with
    :math:`v \ge q` and those with :math:`v \le q` for each decile :math:`q` of ``v``
    (:data:`THRESHOLD_QUANTILES`). Each window's bounds are the smallest and largest value it
    holds; windows holding the same rows are kept once, one holding every row (the global form) is
    not a window, and one with fewer than
    :data:`MIN_REGION_ROWS` rows in every unit, with rows in fewer than two units or in fewer
    than two groups is dropped (the rules of :func:`window_dictionary`).

    Parameters
    ----------
    v : ndarray, shape (n,)
        The column's value on every row.
    units, groups : ndarray of int, shape (n,)
        Held-out unit and run of every row.

    Returns
    -------
    ndarray, shape (k, 2)
    """
    out, seen = [], set()
    for level in np.unique(np.quantile(v, THRESHOLD_QUANTILES)):
        for inside in (v >= level, v <= level):
            if inside.all():  # every row: the global form, not a window
                continue
            per_unit = np.unique(units[inside], return_counts=True)[1]
            if not per_unit.size or per_unit.max() < MIN_REGION_ROWS or per_unit.size < 2:
                continue
            bounds = (float(v[inside].min()), float(v[inside].max()))
            if np.unique(groups[inside]).size >= 2 and bounds not in seen:
                seen.add(bounds)
                out.append(bounds)
    return np.array(out).reshape(-1, 2)


def permutations_can_reject(n_runs: int, n_columns: int, alpha: float) -> bool:
    r"""Whether permuting ``n_runs`` run levels can give a
    p-value Benjamini–Hochberg rejects among ``n_columns``.

    The smallest p-value of a permutation test over :math:`n` runs is :math:`1/n!` (the observed
    arrangement among the :math:`n!`); the first threshold of Benjamini–Hochberg over :math:`m`
    columns is :math:`\alpha/m`. So :math:`n! \ge m/\alpha`.
    """
    return math.factorial(n_runs) * alpha >= n_columns


COLLINEAR_RCOND = 1e-10
"""Smallest singular value, relative to the largest,
below which a window's columns count as collinear."""


def collinear(A: np.ndarray, E: np.ndarray) -> bool:
    r"""Whether a window's columns ``E`` are collinear
    with the model's own design ``A`` (or each other).

    Happens when the candidate holds one value wherever the window has rows (then
    :math:`x\mathbb{1}_W \propto \mathbb{1}_W`) or the window holds every row (then
    :math:`\mathbb{1}_W` is the intercept). The refits then keep the minimum-norm solution; the
    causes table says so in the cause's note.
    """
    M = np.column_stack([A, E])
    M = M / np.maximum(np.linalg.norm(M, axis=0), 1e-300)
    s = np.linalg.svd(M, compute_uv=False)
    return bool(s[-1] <= COLLINEAR_RCOND * s[0])



def indicator(t: np.ndarray, low: float, high: float) -> np.ndarray:
    r""":math:`\mathbb{1}_W(t)` of the window ``[low, high]`` (1.0 inside, 0.0 outside)."""
    return ((t >= low) & (t <= high)).astype(float)


def indicator_columns(t: np.ndarray, windows: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    r"""The indicators :math:`\mathbb{1}_{W_k}` of every
    window alone, and the variants that use them (one each).

    The nested null of the ``local`` form: what the window's own offset buys, which the candidate's
    slope :math:`x\,\mathbb{1}_W` must beat (module docstring).
    """
    W = np.column_stack([indicator(t, low, high)
                         for low, high in windows]) if len(windows) else np.zeros((t.size, 0))
    return W, [np.array([k]) for k in range(W.shape[1])]


def local_columns(x: np.ndarray, t: np.ndarray,
                  windows: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    r"""The columns :math:`[\mathbb{1}_{W_k}, x\,\mathbb{1}_{W_k}]`
    of every window and the variants that use them.

    Parameters
    ----------
    x : ndarray, shape (n,)
        The candidate (or a surrogate of it) on the rows where it is known.
    t : ndarray, shape (n,)
        Order value of the same rows.
    windows : ndarray, shape (k, 2)

    Returns
    -------
    E : ndarray, shape (n, 2k)
    variants : list of ndarray of int
        Columns ``[2k, 2k + 1]`` of each window.
    """
    W = indicator_columns(t, windows)[0]
    E = np.empty((t.size, 2 * W.shape[1]))
    E[:, 0::2], E[:, 1::2] = W, x[:, None] * W
    return E, [np.array([2 * k, 2 * k + 1]) for k in range(W.shape[1])]


def window_axes(data: GapData, code: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each axis the ``local`` form's windows lie along, with its values on every row and its
    windows: the order axis (:func:`window_dictionary`) and every
    ``local_along`` column (:func:`threshold_dictionary`).

    ``code`` is the held-out unit of every row.
    """
    axes = {data.order_name: (data.t, window_dictionary(data.t, code, data.groups))}
    axes.update({name: (v, threshold_dictionary(v, code, data.groups))
                 for name, v in data.along.items()})
    return axes


class WindowAlone:
    """The ``local`` form's nested null: SSE of the leave-one-unit-out refit with a window's
    indicator alone (:func:`indicator_columns`, the window chosen inside
    each fit), per axis and rows known, computed once.

    Parameters
    ----------
    family : LinearTransfer
        The family's refits.
    axes : dict
        :func:`window_axes`.
    """

    def __init__(self, family: LinearTransfer, axes: dict[str, tuple[np.ndarray, np.ndarray]]):
        self.family, self.axes = family, axes
        self._sse: dict[tuple[str, bytes], float] = {}

    def sse(self, axis: str, known: np.ndarray) -> float:
        """SSE on the real rows with the windows along
        ``axis`` alone, fitted on the rows ``known``."""
        key = (axis, np.packbits(known).tobytes())
        if key not in self._sse:
            W, variants = indicator_columns(*self.axes[axis])
            fit = self.family.errors(np.where(known[:, None], W, np.nan), variants, known)
            self._sse[key] = float(fit.errors @ fit.errors)
        return self._sse[key]


def confined_to(family: LinearTransfer, data: GapData, effect: Effect, refit: TransferFit,
                fit: TransferFit) -> dict | None:
    """The stretch of the order axis outside which a global ``effect`` (``fit``: its
    leave-one-unit-out errors; ``refit``: the same-input refit's) transfers worse than the refit,
    or None (module docstring, "A global cause must transfer outside one stretch").

    The stretch is the window of :func:`window_dictionary` whose offset alone the fits choose
    most (:func:`indicator_columns`): where a disturbance no column reads sits, if it sits at one
    place of every run.
    """
    if effect.windows is not None:
        return None
    windows = window_dictionary(data.t, family.units.code, data.groups)
    if not len(windows):
        return None
    W, variants = indicator_columns(data.t, windows)
    alone = family.errors(W, variants, np.ones(data.t.size, dtype=bool))
    region = chosen_region(windows, data.order_name, alone.variant)
    t = data.t[data.is_real]
    outside = (t < region["low"]) | (t > region["high"])
    before, after = refit.errors[outside], fit.errors[outside]
    return region if float(after @ after) > float(before @ before) else None


def confined_reason(effect: Effect, region: dict) -> tuple[str, str]:
    """The cause's note and the verdict's reason when :func:`confined_to` withholds a cause."""
    where = stretch_text(region)
    return f"transfers only {where}", (
        f"The {effect.transform} of {effect.column} passes the transfer test, but it transfers "
        f"only {where}, where the error sits in every run, and worse than the same-input refit "
        "everywhere else: a disturbance at that place of every run, whose size it follows by "
        "chance over so few runs, fits that as well. No cause is named.")


def chosen_region(windows: np.ndarray, axis: str, variant: np.ndarray) -> dict:
    """``{"column": axis, "low": …, "high": …}``: the window the leave-one-unit-out fits chose most
    (``variant``: each fit's window)."""
    low, high = windows[np.bincount(variant, minlength=len(windows)).argmax()]
    return {"column": axis, "low": float(low), "high": float(high)}


def stretch_text(region: dict) -> str:
    """``between 0 and 12 mm of x_mm`` — a stretch of an axis."""
    high = quantity(region["high"], unit_of(region["column"]))
    return f"between {region['low']:.3g} and {high} of {region['column']}"


def region_text(region: dict) -> str:
    """``acting only between 0 and 12 mm of x_mm`` — a local effect's stretch of its axis."""
    return f"acting only {stretch_text(region)}"


def local_note(A: np.ndarray, E: np.ndarray, beyond_window: float, floor: float) -> str | None:
    """The causes table's note on a ``local`` cause, from
    its chosen window's columns ``E`` on the rows fitted.

    Either they are collinear with the family's design ``A`` (:func:`collinear`: the refits keep the
    minimum-norm solution), or the cause's gain beyond its window alone is below the effect
    ``floor`` (the window's own offset transfers about as well); else None.
    """
    if collinear(A, E):
        return ("its window's columns are collinear with the model's own inputs on the rows "
                "fitted: the refits keep the minimum-norm solution")
    if beyond_window < floor:
        return (f"the window's own offset transfers about as well: the column adds "
                f"{shrink_of_gain(beyond_window):.0%} beyond it "
                "(below the effect floor)")
    return None
