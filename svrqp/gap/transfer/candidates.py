r"""The candidate transforms a diagnosis tests, as standardised columns on the real rows.

For a candidate :math:`x` the transforms (:mod:`svrqp.gap.data.transforms`) add the columns

.. math::

    Z_\mathrm{level} = [x],\qquad Z_\mathrm{rate} = [\dot x],\qquad
    Z_\mathrm{lag} = [x, \ell_\tau],\quad \ell_\tau = x_\tau - x,

with :math:`x_\tau` the first-order filtered reading (one variant per time constant
:math:`\tau`); together these span :math:`x_\tau`. A candidate that is also a model feature is
already in the base: its ``level`` is not tested, its ``rate`` :math:`[\dot x]` and ``lag``
:math:`[\ell_\tau]` are. A run-level candidate with enough real runs also gets a bank of its
level tested between runs (:mod:`svrqp.gap.transfer.between`). ``docs/gap.md`` ("How attribution
works") says why each choice was made.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from svrqp.gap.contract import EVIDENCE_BETWEEN, EVIDENCE_WITHIN, MIN_RUNS
from svrqp.gap.data import (
    GapData,
    filter_coefficients,
    group_slices,
    lag,
    lowpass_columns,
    negligible,
    nested_errors,
    rate,
    rise,
    standardised,
)
from svrqp.gap.data.transforms import RISE
from svrqp.gap.transfer.between import RunLevelBank, is_run_level, run_level_bank, run_level_columns
from svrqp.gap.transfer.windows import local_columns


@dataclass(frozen=True)
class LagRecipe:
    r"""How a ``lag`` bank's own columns are computed from the candidate, for its surrogates.

    A lag carries memory: the filter starts in equilibrium with a run's first value, so a
    noisy reading gives every run a transient from its first sample. Rotating the *filtered*
    column would move that transient into the middle of the run, where it breaks the
    surrogate's smoothness and makes the observed column fit a smooth residual better than
    any surrogate. The surrogates therefore rotate the candidate itself and filter it again.

    Attributes
    ----------
    x : ndarray, shape (n_real,)
        The candidate on the real rows.
    alpha : ndarray, shape (n_real, v)
        Filter coefficients (:func:`svrqp.gap.data.transforms.filter_coefficients`), restarting
        at each real group's first row.
    centre, scale : ndarray, shape (v,)
        Standardisation of the observed columns :math:`\ell_\tau`, applied to surrogates alike.
    """

    x: np.ndarray
    alpha: np.ndarray
    centre: np.ndarray
    scale: np.ndarray

    @classmethod
    def of(cls, x: np.ndarray, t: np.ndarray, groups: np.ndarray, taus: np.ndarray) -> LagRecipe:
        """The recipe of candidate values ``x`` on the real rows (order ``t``, groups ``groups``)."""
        alpha = filter_coefficients(t, groups, taus)
        ell = lowpass_columns(x[:, None], alpha)[:, 0, :] - x[:, None]
        centre = ell.mean(axis=0)
        scale = ell.std(axis=0)
        return cls(x, alpha, centre, np.where(negligible(scale, ell), np.inf, scale))

    def own(self, X: np.ndarray) -> np.ndarray:
        r"""Standardised :math:`\ell_\tau` of the series ``X`` (n, s): shape (n, s, v)."""
        out = lowpass_columns(X, self.alpha)
        out -= X[:, :, None]  # in place: for long records these arrays hold millions of values
        out -= self.centre
        out /= self.scale
        return out


@dataclass(frozen=True)
class CandidateBank:
    """Standardised columns of one candidate transform on the real rows.

    Attributes
    ----------
    column : str
        Candidate column.
    transform : str
        ``"level"``, ``"rate"`` or ``"lag"``.
    taus : ndarray or None
        Time constant of each variant (``lag``), else None.
    Z : ndarray, shape (n_real, v)
        Own column of each of the ``v`` variants (time constants).
    partner : ndarray, shape (n_real,) or None
        Column every variant also holds (the level :math:`x` in ``lag`` of an unmodelled
        candidate), else None.
    recipe : LagRecipe or None
        For ``lag``: how surrogates recompute ``Z`` from the rotated candidate.
    """

    column: str
    transform: str
    taus: np.ndarray | None
    Z: np.ndarray
    partner: np.ndarray | None = None
    recipe: LagRecipe | None = None
    evidence: str = EVIDENCE_WITHIN

    def block(self, variant: int) -> np.ndarray:
        """Columns of one variant, shape (n_real, k)."""
        own = self.Z[:, variant : variant + 1]
        return own if self.partner is None else np.column_stack([self.partner, own])

    def tau(self, variant: int) -> float | None:
        """Time constant of a variant (None unless ``lag``)."""
        return None if self.taus is None else float(self.taus[variant])

    def out_of_sample_errors(self, r: np.ndarray, B: np.ndarray, folds: list[np.ndarray],
                             groups: np.ndarray) -> np.ndarray:
        """Errors of ``r ~ B + block`` on the real rows, the variant chosen inside each fold (nested CV)."""
        return nested_errors(r, B, self.Z, self.partner, folds, groups)


Bank = CandidateBank | RunLevelBank
"""Anything :func:`attribute` tests: a candidate transform, or a run-level candidate's level."""


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
    if transform == "rate":
        return rate(x, data.t, data.groups)[:, None], None
    if transform == RISE:
        return rise(x, data.groups)[:, None], None
    ell = lag(x, data.t, data.groups, taus)
    return ell, (None if column in data.features else x)


def region_axis(data: GapData, region: dict) -> np.ndarray:
    """Values, on every row, of the column a ``local`` effect's ``region`` lies along (the order axis or a
    ``local_along`` column)."""
    return data.t if region["column"] == data.order_name else data.along[region["column"]]


def effect_columns(data: GapData, column: str, transform: str, tau: float | None, evidence: str,
                   region: dict | None = None) -> np.ndarray:
    r"""Raw columns of one effect on every row — what a refit of the model adds as inputs.

    A transform's own column (and partner, for ``lag``), for a ``local`` effect its window's
    :math:`[\mathbb{1}_W, x\mathbb{1}_W]` (``region``, :mod:`svrqp.gap.transfer.windows`), or for a
    run-level candidate the block :math:`[\Psi, \bar c, \bar c\Psi]` of :mod:`svrqp.gap.transfer.between`.
    """
    if region is not None:
        x = data.C[:, data.candidates.index(column)]
        return local_columns(x, region_axis(data, region), np.array([[region["low"], region["high"]]]))[0]
    if evidence == EVIDENCE_BETWEEN:
        return run_level_columns(data.C[:, data.candidates.index(column)], data.t, data.groups)
    own, partner = transform_columns(data, column, transform, None if tau is None else np.array([tau]))
    return own if partner is None else np.column_stack([partner, own])


def untestable_between_runs(data: GapData) -> dict[str, str]:
    """Notes on run-level candidates that too few real runs leave untested between runs."""
    real = data.is_real
    groups = data.groups[real]
    n_runs = len(group_slices(groups))
    if n_runs >= MIN_RUNS:
        return {}
    return {column: (f"varies between runs but hardly within them: testing it between runs needs at least "
                     f"{MIN_RUNS} real runs ({n_runs} here)")
            for j, column in enumerate(data.candidates)
            if column not in data.features and is_run_level(data.C[real, j], groups)}


def constant_on_real_rows(data: GapData) -> dict[str, str]:
    """Notes on candidates that hold one value on every real row: no transform of one can explain
    anything there, so its row in the causes table says why rather than only showing no gain."""
    x = data.C[data.is_real]
    constant = negligible(np.ptp(x, axis=0), x)
    return {column: f"constant on the real rows ({x[0, j]:g}): it cannot explain the gap there"
            for j, column in enumerate(data.candidates) if constant[j]}


def build_banks(data: GapData, taus: np.ndarray) -> list[Bank]:
    """Every candidate × transform bank to be tested, standardised on the real rows.

    With at least :data:`svrqp.gap.contract.MIN_RUNS` real runs, a run-level candidate
    (:func:`svrqp.gap.transfer.between.is_run_level`) that is not a model feature also gets a bank
    of its level tested between runs. Its transforms are tested within runs as well: a
    temperature whose level differs by season between runs can still carry the effect's
    dynamics within each of them.
    """
    real = data.is_real
    groups = data.groups[real]
    between = len(group_slices(groups)) >= MIN_RUNS
    banks: list[Bank] = []
    for j, column in enumerate(data.candidates):
        x = data.C[real, j]
        if between and column not in data.features and is_run_level(x, groups):
            banks.append(run_level_bank(column, x, data.t[real], groups))
        partner = None if column in data.features else standardised(x[:, None])[0][:, 0]
        if column not in data.features:
            banks.append(CandidateBank(column, "level", None, partner[:, None]))
        banks.append(CandidateBank(column, "rate", None, standardised(rate(x, data.t[real], groups)[:, None])[0]))
        # The lag restarts at each real group's first row, exactly as its surrogates do.
        recipe = LagRecipe.of(x, data.t[real], groups, taus)
        banks.append(CandidateBank(column, "lag", taus, recipe.own(x[:, None])[:, 0, :], partner, recipe))
    return banks
