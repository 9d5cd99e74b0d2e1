"""The causes of a gap as the transfer ranking holds them: a candidate × transform, its row, and the ranking.

Data only; :mod:`svrqp.gap.transfer.ranking` refits, tests and ranks them (its module docstring states the method).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from svrqp.gap.contract import ALPHA, MIN_GAIN, PROFILE_DEGREE
from svrqp.gap.transfer.linear import TransferFit


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
        :mod:`svrqp.gap.transfer.between` (a level scaling a profile along each run) rather than as the
        plain column (a run-level candidate is refitted both ways).
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
        return {"level": 1, "rate": 1, "lag": 3, "local": 4}[self.transform]


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
        ``{"column": AXIS, "low": …, "high": …}``: the window (of the order axis or a ``local_along``
        column) chosen most often over the fits (``local``).
    note : str or None
    beyond_window : float or None
        Transfer gain of a ``local`` effect over its window's indicator alone (the nested null of
        :mod:`svrqp.gap.transfer.windows`, the window chosen inside each fit there too); None for a global one.
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
    """The column's best transform rotated within runs, whose test stands for a level too few runs leave
    untestable by permutation (module docstring)."""

    @property
    def above_floor(self) -> bool:
        """Its transfer gain reaches the effect floor (a ``local`` effect's also beyond its window alone)."""
        return self.gain >= MIN_GAIN and (self.beyond_window is None or self.beyond_window >= MIN_GAIN)

    @property
    def significant(self) -> bool:
        return self.q_value < ALPHA and self.above_floor


@dataclass
class Ranking:
    """Causes by transfer gain, tested, with the verdict candidate and its confounded rivals."""

    ranked: list[Ranked]
    top: Ranked | None = None
    ambiguous_with: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    withheld: str | None = None
    """Why no verdict is named although a cause is significant (a stronger untestable cause explains it)."""
    too_thin: str | None = None
    """The sentence on a best-transferring run-level cause that too few runs can never make significant."""
    untestable: str | None = None
    """That cause's column (:attr:`too_thin`)."""
