r"""How far the real-row error shrinks once an effect is added — out of sample.

Shrink
    With :math:`r` the baseline residual on the real rows and :math:`e` the out-of-sample
    error of the discrepancy model "base + effect" (blocked cross-validation,
    :mod:`svrqp.gap.discrepancy`),

    .. math::

        \mathrm{RMSE}_\mathrm{before} = \sqrt{\overline{r^2}},\qquad
        \mathrm{RMSE}_\mathrm{after} = \sqrt{\overline{e^2}},\qquad
        \mathrm{shrink} = 1 - \mathrm{RMSE}_\mathrm{after}/\mathrm{RMSE}_\mathrm{before}.

    For ``lag`` the time constant is chosen *inside* each outer fold, by an inner blocked
    cross-validation on that fold's training rows (nested CV), so the choice of :math:`\tau`
    never sees the rows it is scored on. The per-fold fits are plain least squares
    (:func:`numpy.linalg.lstsq`).

Interval
    A moving-block bootstrap within groups (:func:`svrqp.gap.blocks.block_bootstrap`) resamples
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

from svrqp.gap.attribute import transform_columns
from svrqp.gap.baseline import Baseline, fit_predict, make_model
from svrqp.gap.blocks import block_bootstrap, block_length, blocked_folds
from svrqp.gap.discrepancy import CrossValidatedDiscrepancy
from svrqp.gap.prepare import GapData

N_BOOTSTRAP = 1000
"""Bootstrap resamples for the shrink interval."""


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


def _fit_and_predict(r_fit: np.ndarray, D_fit: np.ndarray, D_new: np.ndarray) -> np.ndarray:
    coef = np.linalg.lstsq(D_fit, r_fit, rcond=None)[0]
    return D_new @ coef


def nested_errors(
    r: np.ndarray,
    B: np.ndarray,
    own: np.ndarray,
    partner: np.ndarray | None,
    folds: list[np.ndarray],
    groups: np.ndarray,
) -> np.ndarray:
    """Out-of-sample errors of ``r ~ B + [partner, own[:, variant]]``, variant chosen per fold.

    Parameters
    ----------
    r : ndarray, shape (n,)
        Residual on the real rows.
    B : ndarray, shape (n, p)
        Base regressors (with an intercept).
    own : ndarray, shape (n, v)
        The effect's own column for each of ``v`` variants; with ``v > 1`` the best is
        chosen by inner blocked CV on each outer fold's training rows.
    partner : ndarray, shape (n,) or None
        Column every variant also holds.
    folds : list of ndarray
        Outer blocked folds.
    groups : ndarray of int
        Group code per row (for the inner folds).

    Returns
    -------
    ndarray, shape (n,)
    """
    n, v = own.shape
    errors = np.empty(n)
    for test in folds:
        train = np.setdiff1d(np.arange(n), test, assume_unique=True)
        variant = 0
        if v > 1:
            inner = CrossValidatedDiscrepancy(r[train], B[train], blocked_folds(groups[train]))
            shared = None if partner is None else partner[train, None]
            variant = int(np.argmax(inner.gain(own[train, None, :], shared)[0]))
        columns = [B, own[:, variant]] + ([] if partner is None else [partner])
        D = np.column_stack(columns)
        errors[test] = r[test] - _fit_and_predict(r[train], D[train], D[test])
    return errors


def shrink_interval(before: np.ndarray, after: np.ndarray, groups: np.ndarray, rng: np.random.Generator) -> tuple[float, float]:
    """95 % moving-block bootstrap interval of ``1 - rmse(after)/rmse(before)``."""
    index = block_bootstrap(groups, N_BOOTSTRAP, block_length(before, groups), rng)
    ss_before = (before**2)[index].sum(axis=1)
    ss_after = (after**2)[index].sum(axis=1)
    shrinks = 1 - np.sqrt(ss_after / np.where(ss_before > 0, ss_before, np.nan))
    low, high = np.nanpercentile(shrinks, [2.5, 97.5])
    return float(low), float(high)


def estimate_shrink(
    r: np.ndarray,
    B: np.ndarray,
    own: np.ndarray,
    partner: np.ndarray | None,
    folds: list[np.ndarray],
    groups: np.ndarray,
    rng: np.random.Generator,
) -> ShrinkEstimate:
    """Out-of-sample shrink of the real-row error with an effect's columns added.

    Parameters are those of :func:`nested_errors`, plus ``rng`` for the bootstrap.

    Returns
    -------
    ShrinkEstimate
    """
    after = nested_errors(r, B, own, partner, folds, groups)
    before_rmse = float(np.sqrt(np.mean(r**2)))
    after_rmse = float(np.sqrt(np.mean(after**2)))
    low, high = shrink_interval(r, after, groups, rng)
    shrink = 1 - after_rmse / before_rmse if before_rmse > 0 else 0.0
    return ShrinkEstimate(before_rmse, after_rmse, shrink, low, high, after)


def refit_shrink(data: GapData, baseline: Baseline, column: str, transform: str, tau: float | None) -> float:
    """Shrink of the real-row RMSE after refitting the model family with the effect as input.

    Parameters
    ----------
    data : GapData
        Prepared rows.
    baseline : Baseline
        The baseline (its kind says which family to refit).
    column, transform, tau
        The effect: candidate column, transform name and time constant (``lag`` only).

    Returns
    -------
    float
        ``1 - rmse_refit / rmse_before`` on the real rows.
    """
    own, partner = transform_columns(data, column, transform, None if tau is None else np.array([tau]))
    effect = own if partner is None else np.column_stack([partner, own])
    train, real = data.is_train, data.is_real
    before = float(np.sqrt(np.mean(baseline.residual[real] ** 2)))
    if baseline.kind == "prediction":
        gap = data.y - baseline.y_hat
        correction = make_model("mlr").fit(effect[train], gap[train]).predict(effect)
        after_residual = gap - correction
    else:
        X = np.column_stack([data.X, effect])
        after_residual = data.y - fit_predict(baseline.kind, X[train], data.y[train], X)
    after = float(np.sqrt(np.mean(after_residual[real] ** 2)))
    return 1 - after / before if before > 0 else 0.0
