"""The baseline whose gap is diagnosed: a model fitted on the train rows, or a given prediction.

Model kinds (``--model``), fitted on the train rows only:

``mlr``
    multiple linear regression of the target on the features with an intercept.
``svr``
    :class:`svrqp.estimators.kernel.EpsilonSVR` with an RBF kernel on standardised features and a
    standardised target: ``C = 10``, ``epsilon = 0.05`` (in target standard deviations),
    ``gamma="scale"`` (:math:`1/p` for :math:`p` unit-variance features), solved exactly by
    svrqp's interior point and crossover (``solver="dual_ipm"``): the baseline is refitted once
    per cross-validation fold and once more with the effect, so the fast exact path matters
    (3,012 train rows: 5 s for the whole diagnosis against 59 s through Clarabel).
``lssvr``
    :class:`svrqp.estimators.kernel.LSSVR` with an RBF kernel on standardised features and target:
    ``C = 10``, ``gamma="scale"``.

``mlr`` is :class:`svrqp.estimators.linear.LinearLS`; it returns the minimum-norm solution for
collinear inputs (``rank_deficient="lstsq"``) so that a refit with an added effect column that
is constant on the train rows still works.

The *train reference* residual — the error to expect where nothing is missing — is measured
out of sample and on the footing of the real rows (which the model predicts for runs it never
saw): a model of the same kind is refitted with each train group held out in turn, or with one
train group, each of five contiguous blocks of it (:func:`train_folds`). In prediction mode it is
simply target − prediction on the train rows.

The verdict is also checked the way a user would act on it (:func:`refit_shrink`): the model
family is refitted *on the train rows* with the effect's columns added as inputs and assessed on
the real rows (in prediction mode: a linear correction of target − prediction on the effect's
columns, fitted on the train rows). An effect that does not vary on the train rows cannot be
learned there — a low refit shrink next to a high transfer shrink says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.base import RegressorMixin, clone
from sklearn.compose import TransformedTargetRegressor
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from svrqp import registry
from svrqp.estimators.kernel import LSSVR, EpsilonSVR
from svrqp.estimators.linear import LinearLS
from svrqp.exceptions import ProblemError
from svrqp.gap.data import GapData
from svrqp.metrics import rms

TRAIN_BLOCKS = 5
"""Contiguous blocks of a single train group for its cross-validated reference."""

SVR_C = 10.0
SVR_EPSILON = 0.05
LSSVR_C = 10.0


def make_model(kind: str, gamma: float | str = "scale") -> RegressorMixin:
    """An unfitted regressor of the given kind with the defaults documented above.

    Parameters
    ----------
    kind : {"mlr", "svr", "lssvr"}
        Model family.
    gamma : float or "scale"
        RBF width of a kernel model: ``"scale"`` for the baseline, or a number held fixed (the
        transfer refits keep the baseline's, :mod:`svrqp.gap.transfer.kernel`).

    Returns
    -------
    sklearn regressor
    """
    if kind == "mlr":
        return LinearLS(rank_deficient="lstsq")
    if kind == "svr":
        core = EpsilonSVR(C=SVR_C, epsilon=SVR_EPSILON, gamma=gamma, solver="dual_ipm")
    elif kind == "lssvr":
        core = LSSVR(C=LSSVR_C, gamma=gamma)
    else:
        raise ProblemError(f"model: unknown kind {kind!r}; choose one of {registry.baselines()}")
    return make_pipeline(StandardScaler(), TransformedTargetRegressor(regressor=core, transformer=StandardScaler()))


@dataclass(frozen=True)
class Baseline:
    """Predictions of the baseline on every row and its out-of-sample train reference.

    Attributes
    ----------
    kind : str
        ``"mlr"``, ``"svr"``, ``"lssvr"`` or ``"prediction"``.
    y_hat : ndarray, shape (n,)
        Baseline prediction on every row.
    residual : ndarray, shape (n,)
        ``y - y_hat``.
    train_reference : ndarray, shape (n_train,)
        Out-of-sample residual on the train rows (see module docstring).
    gamma : float or None
        The RBF width :math:`\\gamma` the kernel baseline resolved on its standardised train
        features (``"scale"``: :math:`1/(p\\,\\mathrm{Var})`); None for ``mlr`` and a prediction.
    """

    kind: str
    y_hat: np.ndarray
    residual: np.ndarray
    train_reference: np.ndarray
    gamma: float | None = None


def fit_baseline(data: GapData, kind: str = "mlr") -> Baseline:
    """Fit the baseline on the train rows (or read the prediction) and form residuals.

    Parameters
    ----------
    data : GapData
        Prepared rows.
    kind : {"mlr", "svr", "lssvr"}
        Model family; ignored in prediction mode.

    Returns
    -------
    Baseline
    """
    train = data.is_train
    if data.prediction is not None:
        y_hat = data.prediction
        residual = data.y - y_hat
        return Baseline("prediction", y_hat, residual, residual[train])
    if kind not in registry.baselines():
        raise ProblemError(f"model: unknown kind {kind!r}; choose one of {registry.baselines()}")
    model = clone(make_model(kind)).fit(data.X[train], data.y[train])
    y_hat = np.asarray(model.predict(data.X), dtype=float).ravel()
    gamma = None if kind == "mlr" else float(model[-1].regressor_.gamma_)
    return Baseline(kind, y_hat, data.y - y_hat, train_reference_residual(data, kind), gamma)


def fit_predict(kind: str, X_train: np.ndarray, y_train: np.ndarray, X: np.ndarray,
                gamma: float | str = "scale") -> np.ndarray:
    """Fit a model of ``kind`` (RBF width ``gamma``) on ``(X_train, y_train)`` and predict ``X``."""
    model = clone(make_model(kind, gamma))
    model.fit(X_train, y_train)
    return np.asarray(model.predict(X), dtype=float).ravel()


def train_folds(groups: np.ndarray) -> list[np.ndarray]:
    """Held-out sets of the train reference: on the footing of the real rows, which the model predicts
    for runs it never saw — one whole group at a time when the train rows hold two or more, else
    :data:`TRAIN_BLOCKS` contiguous blocks of the one group (never interleaved short blocks, which
    would interpolate an autocorrelated record)."""
    codes = np.unique(groups)
    if codes.size >= 2:
        return [np.flatnonzero(groups == g) for g in codes]
    position = np.arange(groups.size)
    block = np.minimum(position * TRAIN_BLOCKS // groups.size, TRAIN_BLOCKS - 1)
    return [np.flatnonzero(block == b) for b in range(min(TRAIN_BLOCKS, groups.size))]


def train_reference_residual(data: GapData, kind: str) -> np.ndarray:
    """Cross-validated residual of a ``kind`` model on the train rows (:func:`train_folds`)."""
    X, y, groups = data.X[data.is_train], data.y[data.is_train], data.groups[data.is_train]
    out = np.empty(len(y))
    for test in train_folds(groups):
        fit_rows = np.setdiff1d(np.arange(len(y)), test, assume_unique=True)
        out[test] = y[test] - fit_predict(kind, X[fit_rows], y[fit_rows], X[test])
    return out


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
