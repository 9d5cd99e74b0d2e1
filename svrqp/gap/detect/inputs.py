r"""Is the model used outside what it was fitted on? Its own inputs on the real rows.

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

from svrqp.gap.data import CrossValidatedDiscrepancy, GapData, smooth, standardised
from svrqp.gap.results.records import InputUse
from svrqp.metrics import rms

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
