r"""The model whose gap is diagnosed: the baseline, its refits, and its per-run recalibrations.

**The baseline** (:func:`fit_baseline`). The baseline whose gap is
diagnosed: a model fitted on the train rows, or a given prediction.

Model kinds (``--model``), fitted on the train rows only:

``mlr``
    multiple linear regression of the target on the features with an intercept.
``svr``
    :class:`svrqp.estimators.kernel.EpsilonSVR` with an RBF kernel on standardised features and a
    standardised target: ``C = 10``, ``epsilon = 0.05`` (in target standard deviations),
    ``gamma="scale"`` (:math:`1/p` for :math:`p` unit-variance features), solved exactly by
    svrqp's default exact path and its fallback (``solver="auto"``: SMO and crossover, else the
    interior point and crossover, every answer certified): the baseline is refitted once per
    cross-validation fold and once more with the effect, so the fast exact path matters. A
    same-family transfer refit that still fails its certificate is reported and replaced by the
    linear family's numbers (:mod:`svrqp.gap.transfer.kernel`); it never aborts the diagnosis.
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

**Recalibrations fitted on the real rows** (:func:`base_fit`, :func:`input_use`). Per-run
recalibrations fitted on the real rows: the discrepancy base, and each model input alone.

The base :math:`B` holds offsets (:func:`offset_columns`) and, in features mode, the model's own
inputs (:func:`recalibration_inputs`). The within-real-rows evidence
(:mod:`svrqp.gap.within.attribute`) tests each candidate beyond it; alone, out of sample, it says
what a per-run recalibration would remove (:func:`base_fit`), which no new run gets.

**Every model input against its train range** (:func:`input_use`). Is the
model used outside what it was fitted on? Its own inputs on the real rows.

A model fails on new rows for two reasons that look alike in its residual: something it does
not know about acts there (an unmodelled effect, which :mod:`svrqp.gap.within.attribute` looks for
among the candidates), or something it does know about takes values it never saw — an input
that hardly moved on the train rows, so that its coefficient was never learned, and now moves a
lot. S0's story is the second kind: in summer the ambient air hardly changed, so an MLR on the
air temperature cannot know what an autumn morning does.

For every model feature :math:`x_j` (features mode) and every candidate (``role``) this step reports

* its range on the train rows and on the real rows, and the share of real rows outside the
  train range (:math:`x < \min_\mathrm{train}` or :math:`x > \max_\mathrm{train}`);
* the out-of-sample shrink of the real-row error that recalibrating *that input alone*
  brings: the discrepancy model "offsets + :math:`x_j` (raw and smoothed)" under the blocked
  folds of the diagnosis (:class:`svrqp.gap.data.discrepancy.CrossValidatedDiscrepancy`), against
  the model's raw residual — the part of the discrepancy base
  (:func:`svrqp.gap.model.base_design`) that belongs to this input;
* the input's own part of it, beyond the offsets:
  :math:`1 - \mathrm{RMSE}_{cv}(\text{offsets} + x_j) / \mathrm{RMSE}_{cv}(\text{offsets})`.
  The offsets alone (one per run) can take much of a gap that is mostly a level per run —
  on ``miao2013`` they take 62 % — and that share belongs to no input.

An input outside its train range on most real rows whose recalibration alone removes much of
the error is a model used beyond its data: the remedy is train rows where that input varies,
not another sensor.
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
from svrqp.gap.data import (
    CrossValidatedDiscrepancy,
    GapData,
    holds_out_groups,
    smooth,
    standardised,
)
from svrqp.gap.results.records import BaseFit, InputUse
from svrqp.metrics import rms

# -- the baseline ----------------------------------------------------------------------------------


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
        core = EpsilonSVR(C=SVR_C, epsilon=SVR_EPSILON, gamma=gamma, solver="auto")
    elif kind == "lssvr":
        core = LSSVR(C=LSSVR_C, gamma=gamma)
    else:
        raise ProblemError(f"model: unknown kind {kind!r}; choose one of {registry.baselines()}")
    return make_pipeline(StandardScaler(),
                         TransformedTargetRegressor(regressor=core, transformer=StandardScaler()))


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
    """Held-out sets of the train reference: on the footing of the real rows, which the model
    predicts for runs it never saw — one whole group at a time when the train rows hold two or more,
    else :data:`TRAIN_BLOCKS` contiguous blocks of the one group (never interleaved short blocks,
    which would interpolate an autocorrelated record)."""
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
        every row (a candidate recorded on the real rows
        only cannot enter a refit on the train rows).
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


# -- recalibrations on the real rows ---------------------------------------------------------------


def recalibration_inputs(data: GapData, baseline: Baseline) -> np.ndarray:
    """The model's own inputs in the discrepancy base, on the real rows (may have no column).

    Features mode: the features, and for a non-linear model also its prediction (a linear
    model's prediction is already in the span of its features), each also smoothed
    (:func:`svrqp.gap.data.transforms.smooth`). The smoothed copies matter: sensor noise in the
    inputs biases any recalibration towards zero in the directions where the inputs are
    nearly collinear (errors in variables), and a second, independent reading of a modelled
    temperature — or its own filtered version — would then "explain" that bias without
    being an unmodelled effect.

    Prediction mode: none. Nothing is fitted to a simulation; the discrepancy model explains
    the gap itself. Refitting the prediction's gain would let a candidate "explain" the
    withheld effect by correcting the dynamics of another simulated effect that shares its
    driver (spindle and headstock heating both follow the speed).

    Columns are standardised on the real rows; constant ones are dropped.
    """
    real = data.is_real
    if data.prediction is not None:
        return np.zeros((int(real.sum()), 0))
    inputs = data.X if baseline.kind == "mlr" else np.column_stack([data.X, baseline.y_hat])
    Z, varying = standardised(np.column_stack([inputs, smooth(inputs, data.groups)])[real])
    return Z[:, varying]


def one_offset(groups: np.ndarray) -> bool:
    """Whether the discrepancy base holds one offset for all real rows (groups ``groups``), not one
    per group: when cross-validation holds out whole groups, and when there is one group only."""
    return holds_out_groups(groups) or np.unique(groups).size == 1


def offset_columns(groups: np.ndarray) -> np.ndarray:
    """Offsets of the discrepancy base on the real rows (see :func:`base_design`)."""
    if one_offset(groups):
        return np.ones((groups.size, 1))
    return (groups[:, None] == np.unique(groups)[None, :]).astype(float)


def base_design(data: GapData, baseline: Baseline) -> np.ndarray:
    """Base regressors of the discrepancy models (offsets first, then :func:`recalibration_inputs`).

    Offsets (:func:`offset_columns`): one intercept when the real rows hold enough groups for
    cross-validation to hold out whole groups (:func:`svrqp.gap.data.runs.holds_out_groups`) — an
    offset between groups is then part of the gap a candidate may explain, and differences
    between groups are often the best evidence (an error that scales with each run's feed);
    otherwise one intercept per group, fitted on the other blocks of the same group: with two or
    three groups an offset between them cannot be told apart from any candidate's group means,
    and circular-shift surrogates (which keep each group's level) could never show otherwise.
    """
    return np.column_stack([offset_columns(data.groups[data.is_real]),
                            recalibration_inputs(data, baseline)])


def offsets_text(data: GapData) -> str:
    """The offsets of the discrepancy base in words (:func:`offset_columns`)."""
    if one_offset(data.groups[data.is_real]):
        return "one offset"
    return f"one offset per {data.group_name}"


def base_fit(data: GapData, r: np.ndarray, B: np.ndarray, folds: list[np.ndarray],
             exact: bool) -> BaseFit:
    """The base discrepancy model alone, out of sample:
    what a per-run recalibration would remove."""
    offsets = offsets_text(data)
    description = (
        offsets
        if data.prediction is not None
        else f"{offsets} and a recalibration of the model's inputs"
    )
    rmse_before = float(rms(r))
    if exact:
        return BaseFit(description, 0.0, 0.0)
    errors = CrossValidatedDiscrepancy(r, B, folds).errors_base
    rmse_after = float(rms(errors))
    return BaseFit(description, rmse_after, 1.0 - rmse_after / rmse_before)


def input_use(data: GapData, r: np.ndarray, offsets: np.ndarray,
              folds: list[np.ndarray]) -> list[InputUse]:
    """Range and recalibration check of every model feature and every candidate.

    Parameters
    ----------
    data : GapData
        The prepared rows.
    r : ndarray, shape (n_real,)
        The model's residual on the real rows.
    offsets : ndarray, shape (n_real, k)
        The offset columns of the discrepancy base.
    folds : list of ndarray
        The diagnosis's blocked folds of the real rows.

    Returns
    -------
    list of InputUse
        One per feature, in the order of ``data.features``, then one per candidate that is
        not a feature.
    """
    train, real = data.is_train, data.is_real
    before = float(rms(r))
    offsets_only = float(rms(CrossValidatedDiscrepancy(r, offsets, folds).errors_base))
    uses = []
    columns = [(c, data.X[:, j], "input") for j, c in enumerate(data.features)]
    columns += [(c, data.C[:, j], "candidate")
                for j, c in enumerate(data.candidates) if c not in data.features]
    for column, x, role in columns:
        seen = x[train][np.isfinite(x[train])]
        low, high = (float(seen.min()),
                     float(seen.max())) if seen.size else (float("nan"), float("nan"))
        # A candidate may be unrecorded on the train rows: it is smoothed on the real rows alone.
        smoothed = (
            smooth(x, data.groups)[real] if role == "input" else smooth(x[real], data.groups[real])
        )
        own, varying = standardised(np.column_stack([x[real], smoothed]))
        own = own[:, varying]
        after = float(
            rms(CrossValidatedDiscrepancy(r, np.column_stack([offsets, own]), folds).errors_base)
        )
        shrink = 1.0 - after / before if before > 0 else 0.0
        beyond = 1.0 - after / offsets_only if offsets_only > 0 else None
        outside = float(np.mean((x[real] < low) | (x[real] > high))) if seen.size else 1.0
        uses.append(InputUse(column, low, high, float(x[real].min()), float(x[real].max()), outside,
                             shrink, beyond, role))
    return uses
