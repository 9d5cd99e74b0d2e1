r"""What an effect buys on runs the fit never saw: the transfer numbers of ``docs/gap.md``
("What shrink means").

Held-out units
    Every real row belongs to one *unit* that a fit never sees while it is scored: the
    ``--group`` groups when the real rows span at least two of them, otherwise contiguous
    blocks of the real rows no shorter than the residual's decorrelation length
    (:func:`decorrelation_length`), at least :data:`MIN_BLOCKS` of them
    (:func:`transfer_units`). Never interleaved short blocks: on an autocorrelated record
    those are interpolation. Rows of groups without real rows are in every fit and never scored.

Numbers (features mode, ``mlr``; :math:`A = [1, X]` the model's design on every row)

.. math::

    \mathrm{RMSE}_\mathrm{before} &= \sqrt{\overline{r^2}}\ \text{(the given model on the real
    rows)},\\ \mathrm{RMSE}_\mathrm{refit} &= \sqrt{\overline{(y_u - A_u\hat\beta_{-u})^2}},\quad
        \hat\beta_{-u} = \arg\min \lVert y_{-u} - A_{-u}\beta\rVert^2,\\
    \mathrm{RMSE}_\mathrm{after} &= \sqrt{\overline{(y_u - [A, E_\tau]_u\hat\theta_{-u})^2}},\quad
        \hat\tau_{-u} = \arg\min_\tau \min_\theta \lVert y_{-u} - [A, E_\tau]_{-u}\theta\rVert^2,

averaged over the real rows of every unit :math:`u` (:math:`-u`: all rows of the other
units and the never-scored rows), with :math:`E_\tau` the effect's columns (``level``
:math:`[x]`, ``rate`` :math:`[\dot x]`, ``lag`` :math:`[x, \ell_\tau]`): :math:`\tau` is
chosen inside each fit's own rows. ``shrink`` :math:`= 1 - \mathrm{RMSE}_\mathrm{after}/
\mathrm{RMSE}_\mathrm{before}`, ``shrink_beyond_refit`` :math:`= 1 -
\mathrm{RMSE}_\mathrm{after}/\mathrm{RMSE}_\mathrm{refit}`. With ``--prediction`` the
family is the discrepancy model: :math:`y` is target − prediction and :math:`A = [1]`.

Shared normal equations
    With :math:`V = [A, E, y]` and :math:`G_u = V_u^\top V_u` per unit, the fit without unit
    :math:`u` solves the sub-blocks of :math:`G - G_u`; every time constant and every
    candidate reuses the base block :math:`A^\top A` (a bordered system), so a candidate
    costs one product :math:`V^\top V` per unit and a few small solves, not a refit from the
    rows. Columns are centred and scaled on all rows first (the predictions do not change;
    the normal equations stay well conditioned). A fit with a rank-deficient block (a column
    constant on the fit's rows) takes the minimum-norm solution.

Intervals
    A bootstrap over units (:data:`N_BOOTSTRAP` resamples of the real units with
    replacement) pairs each unit's squared errors before and after.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from svrqp.gap.contract import MAX_BLOCKS, MIN_BLOCKS, N_BOOTSTRAP, THIN_UNITS
from svrqp.gap.data import group_slices
from svrqp.gap.results.records import TransferFit, Units
from svrqp.metrics import rms

_RCOND = 1e-12
"""Relative singular-value cut of a rank-deficient normal-equation block."""



def decorrelation_length(residual: np.ndarray, groups: np.ndarray) -> int:
    """Rows until the residual's autocorrelation (pooled over groups) first falls below 1/e.

    Returns the residual's length when it never does (a trend): no block is then long enough.
    """
    n = residual.size
    acf = np.zeros(n)
    count = 0.0
    for rows in group_slices(groups):
        e = residual[rows] - residual[rows].mean()
        m = e.size
        spectrum = np.abs(np.fft.rfft(e, 2 * m)) ** 2
        acov = np.fft.irfft(spectrum)[:m]
        acf[:m] += acov
        count += float(e @ e)
    if count <= 0:
        return 1
    below = np.flatnonzero(acf / count < np.exp(-1.0))
    return int(below[0]) if below.size else n


def transfer_units(groups: np.ndarray, is_real: np.ndarray, residual: np.ndarray) -> Units:
    """Held-out units of every row (module docstring).

    Parameters
    ----------
    groups : ndarray of int, shape (n,)
        Group code of every row (contiguous, sorted).
    is_real : ndarray of bool, shape (n,)
        Real rows.
    residual : ndarray, shape (n,)
        The model's residual (its real rows set the decorrelation length).

    Returns
    -------
    Units
    """
    code = np.full(groups.size, -1, dtype=np.int64)
    real_groups = [g for g in np.unique(groups[is_real])]
    if len(real_groups) >= 2:
        for u, g in enumerate(real_groups):
            code[groups == g] = u
        return Units(code, "groups", len(real_groups))
    real_rows = np.flatnonzero(is_real)
    length = max(1, decorrelation_length(residual[real_rows], groups[real_rows]))
    n_blocks = min(MAX_BLOCKS, real_rows.size // length)
    short = n_blocks < MIN_BLOCKS
    n_blocks = max(n_blocks, MIN_BLOCKS)
    position = np.arange(real_rows.size)
    code[real_rows] = np.minimum(position * n_blocks // real_rows.size, n_blocks - 1)
    return Units(code, "blocks", n_blocks, int(np.ceil(real_rows.size / n_blocks)), length, short)


def shrink_of_gain(gain: float) -> float:
    r"""The RMSE shrink :math:`1 - \sqrt{1 - g}` that a transfer gain
    :math:`g = 1 - \mathrm{SSE}_1 / \mathrm{SSE}_0` (a relative drop of squared error,
    :mod:`svrqp.gap.transfer.ranking`) amounts to; a gain
    above 1 cannot happen but for rounding and counts as 1."""
    return 1 - float(np.sqrt(max(1 - gain, 0.0)))



class LinearTransfer:
    """Leave-one-unit-out least squares of ``y`` on
    ``[A, E]``, normal equations shared (module docstring).

    Parameters
    ----------
    y : ndarray, shape (n,)
        What the family fits (target, or target − prediction).
    A : ndarray, shape (n, p)
        The family's own design, intercept included.
    units : Units
        Held-out units.
    is_real : ndarray of bool, shape (n,)
        Rows scored.
    """

    def __init__(self, y: np.ndarray, A: np.ndarray, units: Units, is_real: np.ndarray):
        self.units, self.is_real = units, is_real
        self._scale_A = _Scaling.of(A)
        self.y_centre = float(np.mean(y))
        self.y = y - self.y_centre
        self.A = self._scale_A.apply(A)
        self.p = self.A.shape[1]
        self._unit_rows = units.rows()
        self._real_of = [rows[is_real[rows]] for rows in self._unit_rows]
        self._real_position = np.cumsum(is_real) - 1  # row → position among the real rows

    def refit(self) -> TransferFit:
        """The family with its own inputs only: :math:`\\mathrm{RMSE}_\\mathrm{refit}`."""
        return self.errors(np.zeros((self.y.size, 0)), [np.zeros(0, dtype=int)])

    def errors(self, E: np.ndarray, variants: list[np.ndarray],
               known: np.ndarray | None = None) -> TransferFit:
        """Leave-one-unit-out errors with the effect columns ``E`` added.

        Parameters
        ----------
        E : ndarray, shape (n, k)
            Every column any variant uses (non-finite where ``known`` is False).
        variants : list of ndarray of int
            Columns of ``E`` each variant adds (one per time constant for ``lag``); each fit
            keeps the variant with the smallest squared error on its own rows.
        known : ndarray of bool, shape (n,), optional
            Rows where ``E`` is recorded; the others stay out of the fits with the effect (a
            candidate recorded on the real rows only).

        Returns
        -------
        TransferFit
        """
        known = np.isfinite(E).all(axis=1) if known is None else known
        E = np.where(known[:, None], E, 0.0)
        E = _Scaling.of(E[known] if known.any() else E, keep_constant=True).apply(E)
        V = np.column_stack([self.A, E, self.y]) * known[:, None]
        G_total = V.T @ V
        out = np.empty(int(self.is_real.sum()))
        chosen = np.zeros(self.units.n_units, dtype=int)
        # Every variant adds as many columns: their bordered systems are solved as one batch.
        columns = np.array([np.concatenate([np.arange(self.p), self.p + np.asarray(v, dtype=int)])
                            for v in variants])
        y_col = V.shape[1] - 1
        for u, rows in enumerate(self._unit_rows):
            G = G_total - V[rows].T @ V[rows]
            b = G[columns, y_col]
            thetas = _solve_batch(G[columns[:, :, None], columns[:, None, :]], b)
            sse = G[y_col, y_col] - np.einsum("vk,vk->v", thetas, b)
            j = 0
            for i in range(1, len(columns)):  # the first of near-equal fits
                if sse[i] < sse[j] - 1e-12 * abs(G[y_col, y_col]):
                    j = i
            chosen[u] = j
            c, theta = columns[j], thetas[j]
            real = self._real_of[u]
            design = np.column_stack([self.A[real], E[real]])[:, c]
            out[self._real_position[real]] = self.y[real] - design @ theta
        return TransferFit(out, chosen)


@dataclass(frozen=True)
class _Scaling:
    centre: np.ndarray
    scale: np.ndarray

    @classmethod
    def of(cls, M: np.ndarray, keep_constant: bool = False) -> _Scaling:
        """Centre and scale of each column; an all-constant
        column (an intercept) is left as it is."""
        if M.shape[0] == 0:
            return cls(np.zeros(M.shape[1]), np.ones(M.shape[1]))
        centre, scale = M.mean(axis=0), M.std(axis=0)
        constant = scale <= 1e-12 * (1.0 + np.abs(centre))
        centre = centre if keep_constant else np.where(constant, 0.0, centre)
        return cls(centre, np.where(constant, 1.0, scale))

    def apply(self, M: np.ndarray) -> np.ndarray:
        return (M - self.centre) / self.scale


def _solve_batch(G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`_solve` for a stack of systems ``G[i] θ_i = b[i]`` (shapes (v, k, k) and (v, k))."""
    if G.shape[1] == 0:
        return np.zeros(b.shape)
    try:
        L = np.linalg.cholesky(G)
    except np.linalg.LinAlgError:
        return np.array([_solve(Gi, bi) for Gi, bi in zip(G, b, strict=False)])
    pivots = np.diagonal(L, axis1=1, axis2=2) ** 2
    well = pivots.min(axis=1) > _RCOND * np.diagonal(G, axis1=1, axis2=2).max(axis=1)
    out = np.empty(b.shape)
    if well.any():
        out[well] = np.linalg.solve(G[well], b[well][:, :, None])[:, :, 0]
    for i in np.flatnonzero(~well):
        out[i] = _solve(G[i], b[i])
    return out


def _solve(G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve the normal equations ``G θ = b``; the
    minimum-norm solution when ``G`` is rank deficient."""
    if G.shape[0] == 0:
        return np.zeros(0)
    try:
        L = np.linalg.cholesky(G)
        if np.min(np.abs(np.diag(L))) ** 2 > _RCOND * np.max(np.diag(G)):
            return np.linalg.solve(L.T, np.linalg.solve(L, b))
    except np.linalg.LinAlgError:
        pass
    return np.linalg.lstsq(G, b, rcond=_RCOND)[0]


@dataclass(frozen=True)
class TransferShrink:
    """The transfer numbers of one effect (module docstring).

    Attributes
    ----------
    rmse_before, rmse_refit, rmse_after : float
        Real-row RMSE of the given model, of the family refitted leave-one-unit-out, and of that
        refit with the effect.
    shrink, shrink_beyond_refit : float
        ``1 - rmse_after / rmse_before`` and ``1 - rmse_after / rmse_refit``.
    shrink_ci, shrink_beyond_refit_ci : tuple of float or None
        95 % bootstrap intervals over the units; None with fewer than
        :data:`svrqp.gap.contract.THIN_UNITS` units.
    """

    rmse_before: float
    rmse_refit: float
    rmse_after: float
    shrink: float
    shrink_beyond_refit: float
    shrink_ci: tuple[float, float] | None
    shrink_beyond_refit_ci: tuple[float, float] | None


def unit_sums(errors: np.ndarray, real_units: np.ndarray, n_units: int) -> np.ndarray:
    """Sum of squared errors of each unit (``real_units``: unit of each real row)."""
    return np.bincount(real_units, weights=errors**2, minlength=n_units)


def bootstrap_index(n_units: int, rng: np.random.Generator) -> np.ndarray:
    """Units drawn with replacement, :data:`N_BOOTSTRAP`
    resamples (shape (N_BOOTSTRAP, n_units))."""
    return rng.integers(0, n_units, size=(N_BOOTSTRAP, n_units))


def ratio_interval(ss_after: np.ndarray, ss_before: np.ndarray,
                   index: np.ndarray) -> tuple[float, float]:
    """95 % bootstrap interval of ``1 - sqrt(Σ after / Σ before)`` over resampled units."""
    a, b = ss_after[index].sum(axis=1), ss_before[index].sum(axis=1)
    shrinks = 1 - np.sqrt(a / np.where(b > 0, b, np.nan))
    if np.all(np.isnan(shrinks)):
        return 0.0, 0.0
    low, high = np.nanpercentile(shrinks, [2.5, 97.5])
    return float(low), float(high)


def transfer_shrink(before: np.ndarray, refit: np.ndarray, after: np.ndarray,
                    real_units: np.ndarray, n_units: int, index: np.ndarray) -> TransferShrink:
    """The transfer numbers from the real-row errors before, of the refit and with the effect.

    Parameters
    ----------
    before, refit, after : ndarray, shape (n_real,)
        Real-row errors of the given model, the refit and the refit with the effect.
    real_units : ndarray of int, shape (n_real,)
        Unit of each real row.
    n_units : int
        Number of units.
    index : ndarray of int
        Bootstrap resamples of the units (:func:`bootstrap_index`), shared by every effect.

    Returns
    -------
    TransferShrink
    """
    rmse = [float(rms(e)) for e in (before, refit, after)]
    ss = [unit_sums(e, real_units, n_units) for e in (before, refit, after)]
    shrink = 1 - rmse[2] / rmse[0] if rmse[0] > 0 else 0.0
    beyond = 1 - rmse[2] / rmse[1] if rmse[1] > 0 else 0.0
    if n_units < THIN_UNITS:  # too few units for a bootstrap over them to mean anything
        return TransferShrink(rmse[0], rmse[1], rmse[2], shrink, beyond, None, None)
    return TransferShrink(rmse[0], rmse[1], rmse[2], shrink, beyond,
                          ratio_interval(ss[2], ss[0], index), ratio_interval(ss[2], ss[1], index))
