r"""Within the real rows: what a per-run recalibration with an effect would remove, and the train-rows refit.

These are not the report's transfer numbers (:mod:`svrqp.gap.transfer.linear`): the discrepancy model
is fitted on the real rows themselves, so they answer "would a per-run recalibration fix it?"
(``within_shrink`` in the causes table), and the refit on the train rows alone answers "can the
train rows teach the effect?" (``verdict.refit_shrink``).

Shrink within the real rows
    With :math:`r` the baseline residual on the real rows and :math:`e` the out-of-sample
    error of the discrepancy model "base + effect" (blocked cross-validation,
    :mod:`svrqp.gap.data.discrepancy`),

    .. math::

        \mathrm{RMSE}_\mathrm{before} = \sqrt{\overline{r^2}},\qquad
        \mathrm{RMSE}_\mathrm{after} = \sqrt{\overline{e^2}},\qquad
        \mathrm{shrink} = 1 - \mathrm{RMSE}_\mathrm{after}/\mathrm{RMSE}_\mathrm{before}.

    The errors come from the effect's bank: for ``lag`` the time constant is chosen *inside*
    each outer fold, by an inner blocked cross-validation on that fold's training rows
    (nested CV, :func:`svrqp.gap.data.discrepancy.nested_errors`), so the choice of :math:`\tau`
    never sees the rows it is scored on; a run-level candidate's block
    (:mod:`svrqp.gap.transfer.between`) is fitted on the other folds' runs. The per-fold fits are
    least squares.

Interval
    A moving-block bootstrap within groups (:func:`svrqp.gap.data.runs.block_bootstrap`) resamples
    the rows, pairing :math:`r_i` and :math:`e_i`; the 2.5 % and 97.5 % quantiles of the
    resampled shrink form the 95 % interval.

Refit
    The verdict is also checked the way a user would act on it: the baseline's model family is
    refitted *on the train rows* with the effect's columns added as inputs and assessed on the
    real rows (in prediction mode: a linear correction of target − prediction on the effect's
    columns, fitted on the train rows). An effect that does not vary on the train rows cannot
    be learned there — a low refit shrink next to a high shrink says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from svrqp.gap.contract import N_BOOTSTRAP
from svrqp.gap.data.prepare import GapData
from svrqp.gap.data.runs import block_bootstrap, block_length
from svrqp.gap.model.baseline import Baseline, fit_predict, make_model
from svrqp.metrics import rms


@dataclass(frozen=True)
class ShrinkEstimate:
    """Out-of-sample shrink of the real-row error with one effect added.

    Attributes
    ----------
    rmse_before, rmse_after : float
        Real-row RMSE of the baseline and out-of-sample RMSE with the effect.
    shrink : float
        ``1 - rmse_after / rmse_before``.
    ci_low, ci_high : float
        95 % block-bootstrap interval of ``shrink``.
    errors : ndarray
        Out-of-sample errors on the real rows with the effect added.
    """

    rmse_before: float
    rmse_after: float
    shrink: float
    ci_low: float
    ci_high: float
    errors: np.ndarray


def shrink_interval(before: np.ndarray, after: np.ndarray, groups: np.ndarray, rng: np.random.Generator) -> tuple[float, float]:
    """95 % moving-block bootstrap interval of ``1 - rmse(after)/rmse(before)``."""
    index = block_bootstrap(groups, N_BOOTSTRAP, block_length(before, groups), rng)
    ss_before = (before**2)[index].sum(axis=1)
    ss_after = (after**2)[index].sum(axis=1)
    shrinks = 1 - np.sqrt(ss_after / np.where(ss_before > 0, ss_before, np.nan))
    low, high = np.nanpercentile(shrinks, [2.5, 97.5])
    return float(low), float(high)


def estimate_shrink(r: np.ndarray, after: np.ndarray, groups: np.ndarray, rng: np.random.Generator) -> ShrinkEstimate:
    """Out-of-sample shrink of the real-row error with an effect added, and its interval.

    Parameters
    ----------
    r : ndarray, shape (n,)
        Baseline residual on the real rows.
    after : ndarray, shape (n,)
        Out-of-sample errors of the discrepancy model "base + effect" on the same rows
        (:func:`svrqp.gap.data.discrepancy.nested_errors`, or a run-level bank's
        ``out_of_sample_errors``).
    groups : ndarray of int, shape (n,)
        Group code per row (the bootstrap resamples within groups).
    rng : numpy.random.Generator
        Source of the bootstrap resamples.

    Returns
    -------
    ShrinkEstimate
    """
    before_rmse = float(rms(r))
    after_rmse = float(rms(after))
    low, high = shrink_interval(r, after, groups, rng)
    shrink = 1 - after_rmse / before_rmse if before_rmse > 0 else 0.0
    return ShrinkEstimate(before_rmse, after_rmse, shrink, low, high, after)


def refit_shrink(data: GapData, baseline: Baseline, effect: np.ndarray) -> float | None:
    """Shrink of the real-row RMSE after refitting the model family with the effect as input.

    Parameters
    ----------
    data : GapData
        Prepared rows.
    baseline : Baseline
        The baseline (its kind says which family to refit).
    effect : ndarray, shape (n, k)
        The effect's columns on every row (:func:`svrqp.gap.transfer.candidates.effect_columns`).

    Returns
    -------
    float or None
        ``1 - rmse_refit / rmse_before`` on the real rows; None when the effect is not known on
        every row (a candidate recorded on the real rows only cannot enter a refit on the train rows).
    """
    if not np.isfinite(effect).all():
        return None
    train, real = data.is_train, data.is_real
    before = float(rms(baseline.residual[real]))
    if baseline.kind == "prediction":
        gap = data.y - baseline.y_hat
        correction = make_model("mlr").fit(effect[train], gap[train]).predict(effect)
        after_residual = gap - correction
    else:
        X = np.column_stack([data.X, effect])
        after_residual = data.y - fit_predict(baseline.kind, X[train], data.y[train], X)
    after = float(rms(after_residual[real]))
    return 1 - after / before if before > 0 else 0.0
