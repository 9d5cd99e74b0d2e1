"""Step 1 of the diagnosis, the rows: the question checked into arrays (:mod:`.prepare`), the
candidate transforms along the order axis (:mod:`.transforms`), runs, folds and rotations
(:mod:`.runs`) and the cross-validated discrepancy model (:mod:`.discrepancy`)."""

from svrqp.gap.data.discrepancy import CrossValidatedDiscrepancy, nested_errors
from svrqp.gap.data.prepare import GapData, prepare
from svrqp.gap.data.runs import (
    block_bootstrap,
    block_length,
    blocked_folds,
    holds_out_groups,
    lag1_autocorrelation,
    lift_steps,
    rotated_rows,
    shift_offsets,
    wrapped_part,
)
from svrqp.gap.data.transforms import (
    DYNAMIC,
    RISE,
    TRANSFORMS,
    WITHIN_RUN,
    filter_coefficients,
    group_slices,
    lag,
    lowpass_columns,
    negligible,
    rate,
    rise,
    smooth,
    standardised,
    tau_grid,
)

__all__ = [
    "CrossValidatedDiscrepancy", "DYNAMIC", "GapData", "RISE", "TRANSFORMS", "WITHIN_RUN",
    "block_bootstrap",
    "block_length", "blocked_folds", "filter_coefficients", "group_slices", "holds_out_groups",
    "lag", "lag1_autocorrelation", "lift_steps", "lowpass_columns", "negligible", "nested_errors",
    "prepare",
    "rate", "rise", "rotated_rows", "shift_offsets", "smooth", "standardised", "tau_grid",
    "wrapped_part",
]
