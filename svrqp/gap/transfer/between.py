r"""Evidence between runs: candidates that hold one value through each run.

Some candidates barely move while a run lasts and differ from run to run: the temperature of
an axis during a laser pass of a few minutes, the load on the table, the warm-up state of a
motor during a pass of seconds. Their effect is often a *profile along the run that they
scale* — the scale expands by the temperature times the position, a guideway bows by the
motor's temperature times a bow shape. Rotating such a candidate within its run changes
nothing, so the surrogate tests of :mod:`svrqp.gap.within.attribute` can never find it: whatever
evidence there is lies in how the runs differ.

Run-level candidates
    A candidate is *run-level* when its variance within runs is at most
    :data:`RUN_LEVEL_SHARE` of its variance on the real rows (:func:`is_run_level`). Whether its
    plain level is tested by permuting the run levels or by rotating it within runs is decided by
    its within-run movement against its reading noise (:func:`moves_beyond_noise`): a reading whose
    variance within runs exceeds :data:`NOISE_RATIO` times the noise variance its successive
    differences give — a temperature that drifts slowly through each run while its level differs
    far more between runs — is rotated within runs like any other candidate, which is the test its
    within-run movement allows; its block below is still tested between runs. With at
    least :data:`MIN_RUNS` real runs its ``level`` is tested between runs (its transforms
    are still tested within runs too: a temperature whose level differs by season from run
    to run may carry an effect's dynamics within each), through the block

    .. math::

        Z = [\Psi(u),\ \bar c_g,\ \bar c_g\,\Psi(u)],\qquad
        \Psi(u) = [P_1(u), \dots, P_D(u)],

    where :math:`u \in [-1, 1]` is the position along the run (the order value mapped from
    the run's first to its last row), :math:`P_j` are Legendre polynomials
    (:data:`PROFILE_DEGREE`) and :math:`\bar c_g` is the candidate's standardised mean over
    run :math:`g`: a profile common to every run, offsets between runs in proportion to the
    candidate, and a profile that scales with it. The common profile belongs to no
    candidate — like the level :math:`x` next to :math:`\ell_\tau` in ``lag`` it is a
    partner column, but unlike it not the candidate's own: the test, the ranking gain and the
    effect floor ask what the candidate adds to it.

The test, on run summaries (:func:`between_run_test`)
    1. Least squares over the real rows clears the residual of the base, of the blocks
       already accepted and of the common profile: :math:`\tilde r`.
    2. Each run :math:`g` is summarised by the coefficients :math:`a_g` of :math:`\tilde r`
       on :math:`[1, \Psi]` within the run — its offset and its profile.
    3. The summaries are reduced to one number per run, the score :math:`w_g` on their first
       principal direction (the profile that varies most between runs). The direction is
       chosen from the residual alone, never from the candidate, so under "the candidate is
       unrelated to the residual" :math:`w` and :math:`\bar c` stay independent.
    4. :math:`w` is regressed on :math:`\bar c` (next to the run values of any run-level
       column already in the base, for a conditional test); the two-sided p-value of the
       slope comes from Student's t with :math:`k - 2 - q` degrees of freedom (:math:`k`
       real runs, :math:`q` such covariates).

    A run is one observation: with fewer than :data:`MIN_RUNS` real runs the test is not run
    (p = 1) and the report says why.

One run must not carry it
    With a handful of runs, one run far from the others in :math:`\bar c` decides the slope
    alone — an unrelated anomaly in the one cold pass would pass for a relation. The
    relation must therefore also hold with the run of highest leverage left out: the other
    runs must confirm the direction of the slope that the full fit gives (one-sided, at
    :data:`LEAVE_OUT_ALPHA`; ``robust``). This is a condition like the effect floors: it
    decides whether significant evidence counts, not the p-value that enters the
    false-discovery control. With four real runs the other three must line up almost
    exactly, so in practice between-run evidence needs five or more.

Effect floor
    The gain the floors of :mod:`svrqp.gap.within.attribute` apply to is the candidate's own,
    beyond the common profile, out of sample with whole runs held out
    (:func:`svrqp.gap.data.runs.blocked_folds`):
    :math:`1 - \mathrm{SSE}_{cv}(B + Z)/\mathrm{SSE}_{cv}(B + \Psi)`; the gain that ranks
    it among the other candidates is the same difference of errors as a share of the
    base's, :math:`(\mathrm{SSE}_{cv}(B + \Psi) - \mathrm{SSE}_{cv}(B + Z))/\mathrm{SSE}_{cv}(B)`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import legendre
from scipy import stats

from svrqp.gap.contract import EVIDENCE_BETWEEN, MIN_RUNS, PROFILE_DEGREE
from svrqp.gap.data import CrossValidatedDiscrepancy, group_slices, negligible

RUN_LEVEL_SHARE = 0.05
"""A candidate whose within-run variance is at most this share of its variance is run-level."""

LEAVE_OUT_ALPHA = 0.05
"""Level at which the relation must hold with its most influential run left out."""

PARAMETRIC_MIN_RUNS = 5
"""Runs (train and real, the runs a permutation test exchanges) from which a run-level candidate is
tested by :func:`between_run_test` over its real runs in the transfer ranking, when no ordering of
its run levels can reach Benjamini–Hochberg's first threshold (:func:`permutation_floor`): five runs
give 120 orderings, 60 with one repeated level. The t-test's size at five to eight runs is measured
by ``benchmarks/gap_run_level_size.py``. With fewer runs the exact permutation stays the test."""


def permutation_floor(levels: np.ndarray) -> float:
    r"""The smallest p-value any permutation of ``levels`` over the runs can give.

    The orderings that leave the levels as they are: :math:`\prod_i n_i! / k!` for :math:`k` runs
    whose levels take distinct values :math:`n_1, n_2, \dots` times (nine runs at two loads, four
    and five: :math:`4!\,5!/9! = 1/126`). Two levels count as one within 1e-12 of the largest.
    """
    levels = np.sort(np.asarray(levels, dtype=float))
    tolerance = 1e-12 * (1.0 + float(np.abs(levels).max())) if levels.size else 0.0
    starts = np.r_[True, np.diff(levels) > tolerance]
    counts = np.diff(np.r_[np.flatnonzero(starts), levels.size])
    return float(np.exp(sum(math.lgamma(c + 1) for c in counts) - math.lgamma(levels.size + 1)))


def within_sum_of_squares(x: np.ndarray, groups: np.ndarray) -> float:
    """The sum of squares of ``x`` about each run's own mean."""
    return sum(float(np.sum((x[rows] - x[rows].mean()) ** 2)) for rows in group_slices(groups))


def within_share(x: np.ndarray, groups: np.ndarray) -> float:
    """Share of the variance of ``x`` that lies within runs (1.0 for a constant column)."""
    total = float(np.sum((x - x.mean()) ** 2))
    if total <= 1e-24 * (1.0 + float(np.sum(x**2))):
        return 1.0
    return within_sum_of_squares(x, groups) / total


NOISE_RATIO = 4.0
"""A reading whose variance within runs exceeds this multiple of its noise variance moves within
runs."""


def noise_variance(x: np.ndarray, groups: np.ndarray) -> float:
    r"""The variance of a reading's noise, from its successive differences within runs.

    For white noise of variance :math:`\sigma^2` on a signal that changes little from one row to
    the next, :math:`\mathrm{E}[(\Delta x)^2] = 2\sigma^2`; the estimate is
    :math:`\overline{(\Delta x)^2}/2` over every pair of successive rows of a run.
    """
    steps = [np.diff(x[rows]) for rows in group_slices(groups) if rows.stop - rows.start > 1]
    if not steps:
        return 0.0
    d = np.concatenate(steps)
    return 0.5 * float(np.mean(d**2))


def is_run_level(x: np.ndarray, groups: np.ndarray) -> bool:
    """Whether ``x`` varies between runs but hardly within them (see the module docstring)."""
    return within_share(x, groups) <= RUN_LEVEL_SHARE


def moves_beyond_noise(x: np.ndarray, groups: np.ndarray) -> bool:
    """Whether ``x`` varies within runs by more than :data:`NOISE_RATIO` times its noise variance
    (:func:`noise_variance`): then its level is rotated within runs, not permuted between them."""
    return within_sum_of_squares(x, groups) / x.size > NOISE_RATIO * noise_variance(x, groups)


def varies_within(x: np.ndarray, groups: np.ndarray) -> bool:
    """Whether ``x`` (NaN where unknown) moves within
    any run beyond rounding (:func:`negligible`)."""
    known = np.isfinite(x)
    x, groups = x[known], groups[known]
    return any(not negligible(np.ptp(x[rows]),
                              x[rows]) for rows in group_slices(groups) if rows.stop > rows.start)


def run_phase(t: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Position along each run, from -1 at its first row to 1 at its last."""
    u = np.zeros(t.size)
    for rows in group_slices(groups):
        span = t[rows.stop - 1] - t[rows.start]
        if span > 0:
            u[rows] = 2.0 * (t[rows] - t[rows.start]) / span - 1.0
    return u


def profile_columns(t: np.ndarray, groups: np.ndarray, degree: int = PROFILE_DEGREE) -> np.ndarray:
    """Legendre polynomials :math:`P_1 \\dots P_D` of the run phase, shape (n, degree)."""
    u = run_phase(t, groups)
    return np.column_stack([legendre.legval(u, np.eye(degree + 1)[j])
                            for j in range(1, degree + 1)])


def run_means(x: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Every row's run mean of ``x``."""
    out = np.empty(x.size)
    for rows in group_slices(groups):
        out[rows] = x[rows].mean()
    return out


def run_level_columns(x: np.ndarray, t: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """The block :math:`[\\Psi, \\bar c, \\bar c\\Psi]`
    of a candidate on the rows given (unstandardised)."""
    profile = profile_columns(t, groups)
    level = run_means(x, groups)
    return np.column_stack([profile, level, level[:, None] * profile])


@dataclass(frozen=True)
class RunLevelBank:
    """A run-level candidate's ``level``, tested between runs (module docstring).

    Attributes
    ----------
    column : str
        Candidate column.
    profile : ndarray, shape (n_real, D)
        The common profile :math:`\\Psi` on the real rows.
    level : ndarray, shape (n_real,)
        The candidate's run means on the real rows, standardised.
    n_runs : int
        Real runs (the observations of the test).
    """

    column: str
    profile: np.ndarray
    level: np.ndarray
    n_runs: int
    transform: str = "level"
    taus: None = None
    partner: None = None
    evidence: str = EVIDENCE_BETWEEN

    @property
    def testable(self) -> bool:
        """Whether there are enough real runs for the between-run test."""
        return self.n_runs >= MIN_RUNS

    def block(self, variant: int = 0) -> np.ndarray:
        """The columns :math:`[\\Psi, \\bar c, \\bar c\\Psi]`, shape (n_real, 2D + 1)."""
        return np.column_stack([self.profile, self.level, self.level[:, None] * self.profile])

    def tau(self, variant: int = 0) -> None:
        """No time constant."""
        return

    def out_of_sample_errors(self, r: np.ndarray, B: np.ndarray, folds: list[np.ndarray],
                             groups: np.ndarray) -> np.ndarray:
        """Blocked cross-validation errors of ``r ~ B + Z`` on the real rows."""
        return CrossValidatedDiscrepancy(r, np.column_stack([B, self.block()]), folds).errors_base


def run_level_bank(column: str, x: np.ndarray, t: np.ndarray, groups: np.ndarray) -> RunLevelBank:
    """The :class:`RunLevelBank` of candidate values ``x`` on the real rows."""
    level = run_means(x, groups)
    scale = level.std()
    level = (level - level.mean()) / scale if scale > 0 else np.zeros_like(level)
    return RunLevelBank(column, profile_columns(t, groups), level, len(group_slices(groups)))


def _run_values(columns: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Run values of the columns that are constant
    within every run and vary between runs, (k, q)."""
    slices = group_slices(groups)
    columns = columns.reshape(len(columns), -1)
    first = np.array([columns[rows.start] for rows in slices])
    constant = np.ones(columns.shape[1], dtype=bool)
    for g, rows in enumerate(slices):
        constant &= np.all(np.isclose(columns[rows], first[g]), axis=0)
    varying = ~negligible(np.ptp(first, axis=0), first)
    return first[:, constant & varying]


def run_scores(r: np.ndarray, base: np.ndarray, groups: np.ndarray,
               profile: np.ndarray) -> np.ndarray | None:
    """Steps 1–3 of the test: each run's score on the profile that varies most between runs.

    Returns None when the runs do not differ at all.
    """
    cleared = np.column_stack([base, profile])
    r_tilde = r - cleared @ np.linalg.lstsq(cleared, r, rcond=None)[0]
    summaries = np.array(
        [
            np.linalg.lstsq(
                np.column_stack([np.ones(rows.stop - rows.start), profile[rows]]), r_tilde[rows],
                rcond=None,
            )[0]
            for rows in group_slices(groups)
        ]
    )
    centred = summaries - summaries.mean(axis=0)
    _, singular, directions = np.linalg.svd(centred, full_matrices=False)
    if negligible(singular[0], summaries, axis=None):
        return None
    return centred @ directions[0]


def slope_p_value(score: np.ndarray, design: np.ndarray) -> tuple[float, float]:
    """Step 4: the last column's least-squares slope and its two-sided t-test p-value.

    Returns ``(slope, p)``; p is 1.0 when the slope cannot be tested (no degree of freedom
    left, or a rank-deficient design).
    """
    dof = len(score) - design.shape[1]
    if dof < 1 or np.linalg.matrix_rank(design) < design.shape[1]:
        return 0.0, 1.0
    inverse = np.linalg.inv(design.T @ design)
    coef = inverse @ design.T @ score
    variance = float(np.sum((score - design @ coef) ** 2)) / dof * inverse[-1, -1]
    if variance <= 0:
        return float(coef[-1]), 0.0 if abs(coef[-1]) > 0 else 1.0
    return float(coef[-1]), float(2 * stats.t.sf(abs(coef[-1]) / np.sqrt(variance), dof))


@dataclass(frozen=True)
class BetweenRunResult:
    """The between-run test of a run-level candidate (:func:`between_run_test`).

    Attributes
    ----------
    p_value : float
        Two-sided p-value on all real runs.
    p_value_without : float
        One-sided p-value of the same slope with the run of highest leverage left out, in the
        direction the full fit gives.
    robust : bool
        Whether the relation survives without that run (``p_value_without`` below
        :data:`LEAVE_OUT_ALPHA`).
    """

    p_value: float
    p_value_without: float
    robust: bool


def between_run_test(r: np.ndarray, base: np.ndarray, groups: np.ndarray,
                     bank: RunLevelBank) -> BetweenRunResult:
    """The between-run test of ``bank`` given ``base`` (module docstring).

    Parameters
    ----------
    r : ndarray, shape (n,)
        Residual on the real rows.
    base : ndarray, shape (n, p)
        Base regressors and the blocks already accepted.
    groups : ndarray of int, shape (n,)
        Run code per real row (contiguous runs).
    bank : RunLevelBank
        The candidate.

    Returns
    -------
    BetweenRunResult
    """
    untested = BetweenRunResult(1.0, 1.0, False)
    if not bank.testable:
        return untested
    score = run_scores(r, base, groups, bank.profile)
    if score is None:
        return untested
    level = np.array([bank.level[rows.start] for rows in group_slices(groups)])
    design = np.column_stack([np.ones(len(score)), _run_values(base, groups), level])
    slope, p = slope_p_value(score, design)
    if p >= 1.0:
        return untested
    leverage = np.einsum("ij,jk,ik->i", design, np.linalg.inv(design.T @ design), design)
    keep = np.arange(len(score)) != int(np.argmax(leverage))
    slope_without, p_without = slope_p_value(score[keep], design[keep])
    # The full fit says which way the slope goes; the other runs confirm it or not (one-sided).
    one_sided = p_without / 2 if np.sign(slope_without) == np.sign(slope) else 1 - p_without / 2
    return BetweenRunResult(p, one_sided, bool(one_sided < LEAVE_OUT_ALPHA))
