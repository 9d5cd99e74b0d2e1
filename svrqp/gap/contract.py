"""The gap contract's numbers: test levels, effect floors and the least evidence a step needs.

Every rule of ``docs/gap.md`` ("The contract") that is a number lives here, so that one module says
when a cause is significant, when an effect is too small to name, and when the evidence is too thin.
The steps import them from here; nothing else defines them.
"""

ALPHA = 0.05
"""Level of every test; Benjamini–Hochberg false-discovery rate within a round."""

MIN_GAIN = 0.05
"""Relative effect floor: least out-of-sample gain over the base discrepancy model."""

MIN_AMPLITUDE = 0.25
"""Absolute effect floor: least explained RMS, as a fraction of the noise RMS."""

MIN_REAL_ROWS = 20
"""Fewest real (non-train) rows on which a gap can be cross-validated."""

MIN_GROUP_ROWS = 3
"""A group needs at least this many rows (two differences) for rates and filters."""

MIN_RUNS = 4
"""Fewest real runs a between-run test needs (two degrees of freedom for the slope)."""

MIN_BLOCKS = 5
"""Fewest contiguous blocks a record without real runs is cut into."""

MAX_BLOCKS = 10
"""Most contiguous blocks (longer blocks are safer against interpolation)."""

THIN_UNITS = 5
"""With fewer held-out units than this, the transfer evidence is thin: no bootstrap interval is
given (a resample of so few units has too few distinct outcomes to mean anything), and the reason
and summary say the runs are too few for one."""

N_BOOTSTRAP = 1000
"""Bootstrap resamples of the units (or blocks) for the intervals."""

PROFILE_DEGREE = 3
"""Highest Legendre degree :math:`D` of the profile along a run of a between-run effect."""

EVIDENCE_WITHIN = "within runs"
"""``evidence`` of a cause tested by rotations within runs."""

EVIDENCE_BETWEEN = "between runs"
"""``evidence`` of a run-level cause tested between runs."""

EXTRAPOLATING_SHARE = 0.5
"""A model input outside its train range on at least this share of the real rows is extrapolated."""

LINEAR = "linear"
"""Name of the linear family (least squares on shared
normal equations, :mod:`svrqp.gap.transfer.linear`)."""
