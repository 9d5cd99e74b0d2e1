r"""Per-run recalibrations fitted on the real rows: the discrepancy base, and each model input alone.

The base :math:`B` holds offsets (:func:`offset_columns`) and, in features mode, the model's own
inputs (:func:`recalibration_inputs`). The within-real-rows evidence (:mod:`svrqp.gap.within.attribute`)
tests each candidate beyond it; alone, out of sample, it says what a per-run recalibration would
remove (:func:`base_fit`), which no new run gets.

**Every model input against its train range** (:func:`input_use`). Is the model used outside what it was fitted on? Its own inputs on the real rows.

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
  (:func:`svrqp.gap.model.recalibration.base_design`) that belongs to this input;
* the input's own part of it, beyond the offsets:
  :math:`1 - \mathrm{RMSE}_{cv}(\text{offsets} + x_j) / \mathrm{RMSE}_{cv}(\text{offsets})`.
  The offsets alone (one per run) can take much of a gap that is mostly a level per run —
  on ``miao2013`` they take 62 % — and that share belongs to no input.

An input outside its train range on most real rows whose recalibration alone removes much of
the error is a model used beyond its data: the remedy is train rows where that input varies,
not another sensor.
"""

from __future__ import annotations

import numpy as np

from svrqp.gap.data import CrossValidatedDiscrepancy, GapData, holds_out_groups, smooth, standardised
from svrqp.gap.model.baseline import Baseline
from svrqp.gap.results.records import BaseFit, InputUse
from svrqp.metrics import rms


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
    """Whether the discrepancy base holds one offset for all real rows (groups ``groups``), not one per
    group: when cross-validation holds out whole groups, and when there is one group only."""
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
    return np.column_stack([offset_columns(data.groups[data.is_real]), recalibration_inputs(data, baseline)])


def offsets_text(data: GapData) -> str:
    """The offsets of the discrepancy base in words (:func:`offset_columns`)."""
    if one_offset(data.groups[data.is_real]):
        return "one offset"
    return f"one offset per {data.group_name}"


def base_fit(data: GapData, r: np.ndarray, B: np.ndarray, folds: list[np.ndarray], exact: bool) -> BaseFit:
    """The base discrepancy model alone, out of sample: what a per-run recalibration would remove."""
    offsets = offsets_text(data)
    description = offsets if data.prediction is not None else f"{offsets} and a recalibration of the model's inputs"
    rmse_before = float(rms(r))
    if exact:
        return BaseFit(description, 0.0, 0.0)
    errors = CrossValidatedDiscrepancy(r, B, folds).errors_base
    rmse_after = float(rms(errors))
    return BaseFit(description, rmse_after, 1.0 - rmse_after / rmse_before)


def input_use(data: GapData, r: np.ndarray, offsets: np.ndarray, folds: list[np.ndarray]) -> list[InputUse]:
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
    columns += [(c, data.C[:, j], "candidate") for j, c in enumerate(data.candidates) if c not in data.features]
    for column, x, role in columns:
        seen = x[train][np.isfinite(x[train])]
        low, high = (float(seen.min()), float(seen.max())) if seen.size else (float("nan"), float("nan"))
        # A candidate may be unrecorded on the train rows: it is smoothed on the real rows alone.
        smoothed = smooth(x, data.groups)[real] if role == "input" else smooth(x[real], data.groups[real])
        own, varying = standardised(np.column_stack([x[real], smoothed]))
        own = own[:, varying]
        after = float(rms(CrossValidatedDiscrepancy(r, np.column_stack([offsets, own]), folds).errors_base))
        shrink = 1.0 - after / before if before > 0 else 0.0
        beyond = 1.0 - after / offsets_only if offsets_only > 0 else None
        outside = float(np.mean((x[real] < low) | (x[real] > high))) if seen.size else 1.0
        uses.append(InputUse(column, low, high, float(x[real].min()), float(x[real].max()), outside, shrink, beyond,
                             role))
    return uses
