r"""The discrepancy base: what a per-run recalibration fitted on the real rows may use.

The base :math:`B` holds offsets (:func:`offset_columns`) and, in features mode, the model's own
inputs (:func:`recalibration_inputs`). The within-real-rows evidence (:mod:`svrqp.gap.within.attribute`)
tests each candidate beyond it; alone, out of sample, it says what a per-run recalibration would
remove (:func:`base_fit`), which no new run gets.
"""

from __future__ import annotations

import numpy as np

from svrqp.gap.data import CrossValidatedDiscrepancy, GapData, holds_out_groups, smooth, standardised
from svrqp.gap.model.baseline import Baseline
from svrqp.gap.results.records import BaseFit
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
