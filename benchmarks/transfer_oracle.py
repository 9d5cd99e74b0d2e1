r"""Independent transfer refits for the benchmarks of ``svrqp gap`` (imports nothing of ``svrqp.gap``).

DESIGN §4 defines the shrink of a cause as a transfer number: the model family refitted
leave-one-group-out over all rows with the effect added as an input, scored on the real rows,

.. math::

    \mathrm{shrink} = 1 - \frac{\mathrm{RMSE}_{\text{real}}(\text{leave-one-group-out refit with the effect})}
                               {\mathrm{RMSE}_{\text{real}}(\text{the given model})},

and accepts a named column when it is the withheld truth or when its own refit transfers at
least as well as the truth's. The benchmarks score that rule here with plain least squares
(:func:`numpy.linalg.lstsq`), so that the engine's numbers are checked, not reused.

Transforms of a column ``x`` along the order axis ``t``, restarted in every group: ``level``
:math:`[x]`; ``rate`` :math:`[\dot x]` (:func:`numpy.gradient`); ``rise`` :math:`[x - x(t_0)]`, the
change since the group's first row; ``lag`` :math:`[x, x_\tau]`,
the first-order low-pass :math:`x_{\tau,k} = x_{\tau,k-1} + (1 - e^{-(t_k - t_{k-1})/\tau})
(x_k - x_{\tau,k-1})` from equilibrium, one variant per :math:`\tau` of :func:`tau_grid`;
the variant (the :math:`\tau`) is chosen inside each fit by its own rows' squared error.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd

N_TAU = 8
"""Time constants on the grid of the ``lag`` transform."""

AS_WELL = 0.005
"""A named column transfers as well as the truth when its shrink is at most this much smaller (the
tolerance of benchmarks/gap_real.py: two readings of one heat source differ by less)."""

Predict = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
"""``predict(D_fit, y_fit, D_new)``: a model fitted on ``D_fit``, ``y_fit``, evaluated on ``D_new``."""


def lstsq_predict(D_fit: np.ndarray, y_fit: np.ndarray, D_new: np.ndarray) -> np.ndarray:
    """Least-squares fit of ``y_fit`` on ``D_fit``, evaluated on ``D_new``."""
    coef, *_ = np.linalg.lstsq(D_fit, y_fit, rcond=None)
    return D_new @ coef


def median_step_and_span(t: np.ndarray, groups: np.ndarray) -> tuple[float, float]:
    """The median sampling step and the median group span of ``t`` (rows sorted within groups)."""
    steps, spans = [], []
    for g in pd.unique(groups):
        tg = t[groups == g]
        steps.extend(np.diff(tg))
        spans.append(tg[-1] - tg[0])
    return (float(np.median(steps)) if steps else float("nan")), float(np.median(spans))


def tau_grid(t: np.ndarray, groups: np.ndarray, n_tau: int = N_TAU) -> np.ndarray:
    """Geometric grid from two median sampling steps (at least 1 % of the median group span) to half
    that span."""
    step, span = median_step_and_span(t, groups)
    low = max(2 * step, span / 100)
    return np.geomspace(low, max(span / 2, 2 * low), n_tau)


def lowpass(x: np.ndarray, t: np.ndarray, groups: np.ndarray, taus: np.ndarray) -> np.ndarray:
    r"""First-order low-pass of ``x`` for each ``tau`` (columns), from each group's first value
    (:math:`\tau = \infty` holds it); rows sorted by ``t`` within each group."""
    out = np.empty((x.size, taus.size))
    for g in pd.unique(groups):
        rows = np.flatnonzero(groups == g)
        state = np.full(taus.size, x[rows[0]])
        out[rows[0]] = state
        gain = 1.0 - np.exp(-np.diff(t[rows])[:, None] / taus[None, :])
        for k in range(1, rows.size):
            state = state + gain[k - 1] * (x[rows[k]] - state)
            out[rows[k]] = state
    return out


def rate_and_start(x: np.ndarray, t: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rate of ``x`` along ``t`` (:func:`numpy.gradient`) and each group's first value, per row."""
    rate, start = np.empty_like(x), np.empty_like(x)
    for g in pd.unique(groups):
        rows = np.flatnonzero(groups == g)
        rate[rows] = np.gradient(x[rows], t[rows]) if rows.size > 1 else 0.0
        start[rows] = x[rows[0]]
    return rate, start


def between_block(x: np.ndarray, t: np.ndarray, groups: np.ndarray, degree: int = 3) -> np.ndarray:
    r"""The between-run block :math:`[P, \bar x, \bar x P]`: the group mean :math:`\bar x` scaling the
    Legendre polynomials :math:`P` of degree 1 to ``degree`` of the group phase (−1 at a group's first
    row, 1 at its last)."""
    frame = pd.DataFrame({"t": t, "g": groups, "x": x})
    first = frame.groupby("g")["t"].transform("min").to_numpy(float)
    last = frame.groupby("g")["t"].transform("max").to_numpy(float)
    phase = 2.0 * (t - first) / np.where(last > first, last - first, 1.0) - 1.0
    profile = np.polynomial.legendre.legvander(phase, degree)[:, 1:]
    level = frame.groupby("g")["x"].transform("mean").to_numpy(float)[:, None]
    return np.column_stack([profile, level, level * profile])


def transform_variants(x: np.ndarray, t: np.ndarray, groups: np.ndarray,
                       taus: np.ndarray) -> dict[str, list[np.ndarray]]:
    """Input columns of each transform of ``x`` (module docstring); ``lag`` has one variant per ``tau``.

    Rows must be sorted by ``t`` within each group.
    """
    x = np.asarray(x, dtype=float)
    rate, start = rate_and_start(x, t, groups)
    lagged = lowpass(x, t, groups, taus)
    return {"level": [x[:, None]], "rate": [rate[:, None]], "rise": [(x - start)[:, None]],
            "lag": [np.column_stack([x, lagged[:, j]]) for j in range(taus.size)]}


def logo_rmse(y: np.ndarray, base: np.ndarray, variants: list[np.ndarray], groups: np.ndarray,
              real: np.ndarray, predict: Predict = lstsq_predict) -> float:
    """Real-row RMSE of the leave-one-group-out refit of ``y`` on ``base`` plus the best variant.

    Every group holding real rows is predicted by a fit on all other rows (train and real); with
    several variants, each fit keeps the one with the smallest squared error on its own rows.
    """
    squared = []
    for held in pd.unique(groups[real]):
        fit, new = groups != held, (groups == held) & real
        best, best_sse = None, np.inf
        for extra in variants:
            D = np.column_stack([base, extra])
            if len(variants) == 1:
                best = predict(D[fit], y[fit], D[new])
                break
            both = predict(D[fit], y[fit], np.vstack([D[fit], D[new]]))
            sse = float(np.sum((y[fit] - both[: fit.sum()]) ** 2))
            if sse < best_sse:
                best, best_sse = both[fit.sum():], sse
        squared.append((y[new] - best) ** 2)
    return float(np.sqrt(np.mean(np.concatenate(squared))))


def column_shrinks(table: pd.DataFrame, y: np.ndarray, base: np.ndarray, rmse_before: float, column: str,
                   order: str, group: str, real: np.ndarray, predict: Predict = lstsq_predict) -> dict[str, float]:
    """Transfer shrink of ``column`` under each transform (rows sorted by ``order`` within ``group``)."""
    t, groups = table[order].to_numpy(float), table[group].to_numpy()
    banks = transform_variants(table[column].to_numpy(float), t, groups, tau_grid(t, groups))
    return {name: 1 - logo_rmse(y, base, variants, groups, real, predict) / rmse_before
            for name, variants in banks.items()}


def best_shrink(table: pd.DataFrame, y: np.ndarray, base: np.ndarray, rmse_before: float, columns: tuple[str, ...],
                order: str, group: str, real: np.ndarray, predict: Predict = lstsq_predict) -> float:
    """The largest transfer shrink of any of ``columns`` under any transform (``nan`` for none)."""
    return max((max(column_shrinks(table, y, base, rmse_before, c, order, group, real, predict).values())
                for c in columns), default=float("nan"))


def as_well_as_truth(table: pd.DataFrame, y: np.ndarray, base: np.ndarray, rmse_before: float,
                     named: str | None, transform: str | None, truth: tuple[str, ...], truth_shrink: float,
                     order: str, group: str, real: np.ndarray, predict: Predict = lstsq_predict) -> tuple[bool, float]:
    """DESIGN §4's acceptance of a verdict, by independent refits.

    Returns whether ``named`` is a truth column, or transfers with its ``transform`` at least as well
    as ``truth_shrink`` (the best truth column under its best transform, :func:`best_shrink`; within
    :data:`AS_WELL`), and
    the named column's shrink (``nan`` without a verdict or for a truth column).
    """
    if named is None or named in truth:
        return named is not None, float("nan")
    shrink = column_shrinks(table, y, base, rmse_before, named, order, group, real, predict)[transform]
    return bool(shrink >= truth_shrink - AS_WELL), shrink
