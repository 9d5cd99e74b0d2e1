r"""The columns of an effect, a candidate × transform,
on every row; and the candidates that cannot be tested.

For a candidate :math:`x` the transforms (:mod:`svrqp.gap.data.transforms`) give the columns

.. math::

    Z_\mathrm{level} = [x],\qquad Z_\mathrm{rate} = [\dot x],\qquad
    Z_\mathrm{lag} = [x, \ell_\tau],\quad \ell_\tau = x_\tau - x,

with :math:`x_\tau` the first-order filtered reading at the time constant :math:`\tau`
(:func:`transform_columns`). :func:`effect_columns` adds them to the verdict's refit on the train
rows; a run-level effect's profile columns come from :mod:`svrqp.gap.transfer.between`, a local
one's from :mod:`svrqp.gap.transfer.windows`. The within-real-rows banks built from the same
transforms are in :mod:`svrqp.gap.within.surrogate_tests`. ``docs/gap.md`` ("How attribution
works") says why each choice was made.
"""

from __future__ import annotations

import numpy as np

from svrqp.gap.contract import EVIDENCE_BETWEEN, MIN_RUNS
from svrqp.gap.data import DYNAMIC, GapData, group_slices, lag, negligible
from svrqp.gap.transfer.between import is_run_level, run_level_columns
from svrqp.gap.transfer.windows import local_columns


def transform_columns(
    data: GapData, column: str, transform: str, taus: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Raw (unstandardised) columns of a transform on every row.

    Returns
    -------
    own : ndarray, shape (n, v)
        ``level``: :math:`x`; ``rate``: :math:`\\dot x`; ``rise``: :math:`x - x(t_0)`; ``lag``:
        :math:`\\ell_\\tau` per ``tau``.
    partner : ndarray, shape (n,) or None
        :math:`x` for ``lag`` of a candidate that is not a model feature, else None.
    """
    x = data.C[:, data.candidates.index(column)]
    if transform == "level":
        return x[:, None], None
    if transform in DYNAMIC:
        return DYNAMIC[transform](x, data.t, data.groups)[:, None], None
    ell = lag(x, data.t, data.groups, taus)
    return ell, (None if column in data.features else x)


def region_axis(data: GapData, region: dict) -> np.ndarray:
    """Values, on every row, of the column a ``local`` effect's ``region`` lies along (the order
    axis or a ``local_along`` column)."""
    return data.t if region["column"] == data.order_name else data.along[region["column"]]


def effect_columns(data: GapData, column: str, transform: str, tau: float | None, evidence: str,
                   region: dict | None = None) -> np.ndarray:
    r"""Raw columns of one effect on every row — what a refit of the model adds as inputs.

    A transform's own column (and partner, for ``lag``), for a ``local`` effect its window's
    :math:`[\mathbb{1}_W, x\mathbb{1}_W]` (``region``, :mod:`svrqp.gap.transfer.windows`), or for a
    run-level candidate the block :math:`[\Psi, \bar c, \bar c\Psi]`
    of :mod:`svrqp.gap.transfer.between`.
    """
    if region is not None:
        x = data.C[:, data.candidates.index(column)]
        return local_columns(x, region_axis(data, region),
                             np.array([[region["low"], region["high"]]]))[0]
    if evidence == EVIDENCE_BETWEEN:
        return run_level_columns(data.C[:, data.candidates.index(column)], data.t, data.groups)
    own, partner = transform_columns(data, column, transform,
                                     None if tau is None else np.array([tau]))
    return own if partner is None else np.column_stack([partner, own])


def untestable_between_runs(data: GapData) -> dict[str, str]:
    """Notes on run-level candidates that too few real runs leave untested between runs."""
    real = data.is_real
    groups = data.groups[real]
    n_runs = len(group_slices(groups))
    if n_runs >= MIN_RUNS:
        return {}
    return {column: ("varies between runs but hardly within them: testing it between runs needs "
                     f"at least {MIN_RUNS} real runs ({n_runs} here)")
            for j, column in enumerate(data.candidates)
            if column not in data.features and is_run_level(data.C[real, j], groups)}


def constant_on_real_rows(data: GapData) -> dict[str, str]:
    """Notes on candidates that hold one value on every real row: no transform of one can explain
    anything there, so its row in the causes table says why rather than only showing no gain."""
    x = data.C[data.is_real]
    constant = negligible(np.ptp(x, axis=0), x)
    return {column: f"constant on the real rows ({x[0, j]:g}): it cannot explain the gap there"
            for j, column in enumerate(data.candidates) if constant[j]}
