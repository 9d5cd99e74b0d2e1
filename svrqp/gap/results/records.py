"""The diagnosis's records, below every step: data only, nothing computed here.

The gate's numbers (:class:`GateResult`), a region of the error (:class:`Region`), a model input
against its train range (:class:`InputUse`), a transfer refit's errors (:class:`TransferFit`), a
candidate × transform and its ranking (:class:`Effect`, :class:`Ranked`, :class:`Ranking`), a row
of the causes table (:class:`Cause`), the verdict (:class:`Verdict`), the per-run recalibration
base (:class:`BaseFit`) and the per-row data the figures draw (:class:`Series`). The steps that
compute them are in the sub-packages above; :mod:`svrqp.gap.transfer.ranking` states how effects
are refitted, tested and ranked.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from svrqp.gap.contract import ALPHA, EXTRAPOLATING_SHARE, MIN_GAIN, PROFILE_DEGREE, THIN_UNITS


@dataclass(frozen=True)
class Effect:
    r"""One candidate transform as the refits add it.

    Attributes
    ----------
    column, transform : str
        The candidate and its transform.
    taus : ndarray or None
        The time-constant grid (``lag``).
    run_level : bool
        The candidate holds one level per run: surrogates permute its run levels.
    block : bool
        Its ``level`` enters as the block :math:`[\Psi, \bar c, \bar c\Psi]` of
        :mod:`svrqp.gap.transfer.between` (a level scaling a profile along each run) rather than as
        the plain column (a run-level candidate is refitted both ways).
    """

    column: str
    transform: str
    taus: np.ndarray | None
    run_level: bool
    block: bool = False
    windows: np.ndarray | None = None
    """The windows ``[low, high]`` searched (``local``, :mod:`svrqp.gap.transfer.windows`)."""
    axis: str | None = None
    """The column the windows lie along (``local``): the order axis, or a ``local_along`` column."""

    @property
    def parameters(self) -> int:
        """Columns added plus a fitted time constant or window bounds."""
        if self.block:
            return 2 * PROFILE_DEGREE + 1
        return {"lag": 3, "local": 4}.get(self.transform, 1)  # level and the one-column dynamics: 1

    def chosen_tau(self, variant: np.ndarray) -> float | None:
        """The time constant the units' fits chose most often (``variant``: each fit's index in
        :attr:`taus`), or None without a grid."""
        if self.taus is None:
            return None
        return float(self.taus[np.bincount(variant, minlength=self.taus.size).argmax()])


@dataclass
class Ranked:
    """One column's best-transferring effect and its errors.

    Attributes
    ----------
    effect : Effect
    fit : TransferFit
        Leave-one-unit-out errors with the effect (and the time constant each fit chose).
    gain : float
        Transfer gain (module docstring).
    p_raw, q_value : float
        Surrogate p-value (1 when untested) and its Benjamini–Hochberg adjustment.
    tau : float or None
        The time constant chosen most often over the fits (``lag``).
    region : dict or None
        ``{"column": AXIS, "low": …, "high": …}``: the window (of the order axis or a
        ``local_along`` column) chosen most often over the fits (``local``).
    note : str or None
    beyond_window : float or None
        Transfer gain of a ``local`` effect over its window's indicator alone (the nested null of
        :mod:`svrqp.gap.transfer.windows`, the window chosen
        inside each fit there too); None for a global one.
    """

    effect: Effect
    fit: TransferFit
    gain: float
    p_raw: float = 1.0
    q_value: float = 1.0
    tau: float | None = None
    note: str | None = None
    tested: bool = False
    ambiguous: bool = False
    region: dict | None = None
    beyond_window: float | None = None
    tested_by: Ranked | None = None
    """The column's best transform rotated within runs, whose test stands for a level too few runs
    leave untestable by permutation (module docstring)."""

    @property
    def above_floor(self) -> bool:
        """Its transfer gain reaches the effect floor (a
        ``local`` effect's also beyond its window alone)."""
        return self.gain >= MIN_GAIN and (self.beyond_window is None
                                          or self.beyond_window >= MIN_GAIN)

    @property
    def significant(self) -> bool:
        return self.q_value < ALPHA and self.above_floor

    def fixed_effect(self) -> Effect:
        """Its effect with the time constant (or window) fixed at the one its fits chose most."""
        if self.region is not None:
            return dataclasses.replace(
                self.effect, windows=np.array([[self.region["low"], self.region["high"]]]))
        if self.tau is None:
            return self.effect
        return dataclasses.replace(self.effect, taus=np.array([self.tau]))


@dataclass
class Ranking:
    """Causes by transfer gain, tested, with the verdict candidate and its confounded rivals."""

    ranked: list[Ranked]
    top: Ranked | None = None
    ambiguous_with: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    withheld: str | None = None
    """Why no verdict is named although a cause is
    significant (a stronger untestable cause explains it)."""
    too_thin: str | None = None
    """The sentence on a best-transferring run-level
    cause that too few runs can never make significant."""
    untestable: str | None = None
    """That cause's column (:attr:`too_thin`)."""


@dataclass(frozen=True)
class Cause:
    """One row of the causes table, ranked by transfer gain (:mod:`svrqp.gap.transfer.ranking`).

    ``rmse_before``, ``rmse_refit``, ``rmse_after``, ``shrink``, ``shrink_ci``,
    ``shrink_beyond_refit`` and its interval are the transfer numbers of
    :mod:`svrqp.gap.transfer.linear`; ``gain``, ``p_raw`` and ``p_value`` those of the transfer
    test. The ``within_*`` keys, ``p_within`` and ``shrink_beyond_base`` come from the discrepancy
    model fitted on the real rows themselves (:mod:`svrqp.gap.within.attribute`): what a per-run
    recalibration would remove, never a transfer number. ``family`` names the model family the
    transfer numbers were refitted with (:mod:`svrqp.gap.transfer.kernel`): the baseline's own, or
    ``"linear"`` for the causes only the linear screen refitted. ``shrink_beyond_window`` (a
    ``local`` cause only) is ``1 - rmse_after / rmse_window`` by the linear screen, ``rmse_window``
    the refit with the window's indicator alone (:mod:`svrqp.gap.transfer.windows`): what the column
    adds beyond the window's own offset.
    """

    column: str
    transform: str
    tau: float | None
    evidence: str
    p_value: float
    p_raw: float
    gain: float
    significant: bool
    rmse_before: float
    rmse_after: float
    shrink: float
    shrink_ci: tuple[float, float] | None
    note: str | None = None
    ambiguous: bool = False
    shrink_beyond_base: float | None = None
    rmse_refit: float | None = None
    shrink_beyond_refit: float | None = None
    shrink_beyond_refit_ci: tuple[float, float] | None = None
    tested: bool = False
    p_within: float | None = None
    within_shrink: float | None = None
    within_shrink_ci: tuple[float, float] | None = None
    family: str = "linear"
    region: dict[str, Any] | None = None
    shrink_beyond_window: float | None = None


@dataclass(frozen=True)
class Verdict:
    """The single cause the engine stands behind (``column is None`` when there is none)."""

    column: str | None
    reason: str
    transform: str | None = None
    tau: float | None = None
    evidence: str | None = None
    shrink: float | None = None
    shrink_ci: tuple[float, float] | None = None
    refit_shrink: float | None = None
    rmse_before: float | None = None
    rmse_after: float | None = None
    p_value: float | None = None
    ambiguous_with: list[str] = field(default_factory=list)
    rmse_refit: float | None = None
    shrink_beyond_refit: float | None = None
    shrink_beyond_refit_ci: tuple[float, float] | None = None
    thin: bool = False
    family: str | None = None
    untestable: str | None = None
    """A run-level column that transfers best but that too few runs can never make significant
    (:attr:`svrqp.gap.results.records.Ranking.too_thin`)."""
    region: dict[str, Any] | None = None
    """``{"column": ORDER, "low": …, "high": …}``: the stretch of the order axis (or of a
    ``local_along`` column) a ``local`` effect acts in
    (:mod:`svrqp.gap.transfer.windows`); None for a global effect."""


@dataclass(frozen=True)
class BaseFit:
    """What the discrepancy base alone, fitted on the real
    rows themselves, removes: a per-run recalibration.

    The base (per-group offsets and, in features mode, a recalibration of the model's own inputs)
    is what the within-real-rows numbers of a cause (``within_shrink``, ``shrink_beyond_base``)
    build on; no new run gets it, so it never enters a transfer shrink.

    Attributes
    ----------
    description : str
        The base's columns in words.
    rmse_after : float
        Out-of-sample real-row RMSE of the base alone.
    shrink : float
        ``1 - rmse_after / rmse_before`` (``rmse_before`` = the model's real-row RMSE).
    """

    description: str
    rmse_after: float
    shrink: float


@dataclass(frozen=True)
class TransferFit:
    """Leave-one-unit-out errors on the real rows of one design.

    Attributes
    ----------
    errors : ndarray, shape (n_real,)
        Out-of-unit error of every real row (in row order).
    variant : ndarray of int, shape (n_units,)
        The variant (time constant) each unit's fit chose on its own rows.
    """

    errors: np.ndarray
    variant: np.ndarray


@dataclass(frozen=True)
class GateResult:
    """Outcome of the gap tests on one residual.

    Attributes
    ----------
    train_rmse : float
        Out-of-sample RMSE on the train rows (the reference).
    real_rmse : float
        RMSE of the residual on the real rows.
    ratio : float
        ``real_rmse / train_rmse``.
    p_excess : float
        p-value of the excess-error F test (real rows against the train reference).
    noise_rmse : float
        Noise level from successive differences of the real-row residual.
    p_noise : float
        p-value of the F test of the real-row error against that noise level.
    p_white : float
        Ljung–Box p-value of the real-row residual.
    rho1 : float
        Lag-1 autocorrelation of the real-row residual.
    """

    train_rmse: float
    real_rmse: float
    ratio: float
    p_excess: float
    noise_rmse: float
    p_noise: float
    p_white: float
    rho1: float


@dataclass(frozen=True)
class InputUse:
    """How the real rows use one model input.

    Attributes
    ----------
    column : str
        The feature.
    train_low, train_high : float
        Its range on the train rows.
    real_low, real_high : float
        Its range on the real rows.
    outside : float
        Share of the real rows outside the train range.
    recalibration_shrink : float
        Out-of-sample shrink of the real-row error by offsets and this input alone
        (module docstring).
    beyond_offsets : float or None
        What this input's recalibration removes of the error the offsets alone leave, out of
        sample (None when the offsets leave no error).
    role : {"input", "candidate"}
        A model input, or a candidate (its train range is read where it is recorded; NaN
        when it is recorded on the real rows only).
    """

    column: str
    train_low: float
    train_high: float
    real_low: float
    real_high: float
    outside: float
    recalibration_shrink: float
    beyond_offsets: float | None
    role: str = "input"

    @property
    def extrapolated(self) -> bool:
        """Whether most real rows lie outside the train range (:data:`EXTRAPOLATING_SHARE`)."""
        return self.outside >= EXTRAPOLATING_SHARE


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
        Held-out mean squared error in the region over the held-out overall mean (of the run,
        for a region within one run).
    group : str or None
        The run the region lies in; None when it is pooled over every real run.
    share_of_run : float or None
        Region's fraction of its run's squared error (None when pooled).
    """

    column: str
    low: float
    high: float
    rmse: float
    share: float
    n: int
    enrichment: float
    group: str | None = None
    share_of_run: float | None = None


@dataclass(frozen=True)
class Series:
    """What the figures draw, per row (sorted by group and order).

    Attributes
    ----------
    target, order_name : str
        Column names (for labels).
    t : ndarray
        Order values.
    groups : ndarray of int
        Group code per row.
    group_labels : list of str
        Label per group code.
    is_train : ndarray of bool
        Train rows.
    y, y_hat : ndarray
        Measured target and baseline prediction.
    after : ndarray or None
        Out-of-sample error on the real rows with the verdict's effect added.
    """

    target: str
    order_name: str
    t: np.ndarray
    groups: np.ndarray
    group_labels: list[str]
    is_train: np.ndarray
    y: np.ndarray
    y_hat: np.ndarray
    after: np.ndarray | None


@dataclass(frozen=True)
class Units:
    """The held-out units of the transfer refits.

    Attributes
    ----------
    code : ndarray of int, shape (n,)
        Unit of each row; -1 for rows that are in every fit and never scored.
    kind : {"groups", "blocks"}
        Whole ``--group`` groups, or contiguous blocks of the real rows.
    n_units : int
        Number of held-out units.
    block_rows : int or None
        Rows per block (blocks only).
    decorrelation_rows : int or None
        The residual's decorrelation length in rows (blocks only).
    short : bool
        The record is too short for :data:`MIN_BLOCKS` blocks of the decorrelation length:
        it is cut into :data:`MIN_BLOCKS` shorter blocks anyway (stated fallback; the transfer
        numbers are then optimistic).
    """

    code: np.ndarray
    kind: str
    n_units: int
    block_rows: int | None = None
    decorrelation_rows: int | None = None
    short: bool = False

    @property
    def thin(self) -> bool:
        """Whether too few units hold the transfer evidence (:data:`THIN_UNITS`)."""
        return self.n_units < THIN_UNITS

    def rows(self) -> list[np.ndarray]:
        """Row indices of each unit."""
        return [np.flatnonzero(self.code == u) for u in range(self.n_units)]

    def as_dict(self) -> dict:
        """The ``blocks`` entry of the JSON."""
        return {"kind": self.kind, "n": self.n_units, "rows_per_block": self.block_rows,
                "decorrelation_rows": self.decorrelation_rows,
                "shorter_than_decorrelation": self.short, "thin": self.thin}
