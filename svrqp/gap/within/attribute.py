r"""Which candidate, in which transform, carries information about the real-row residual.

For a candidate :math:`c` and transform :math:`t` (:mod:`svrqp.gap.transfer.candidates`) the
discrepancy model of :mod:`svrqp.gap.data.discrepancy` adds the columns :math:`Z_{c,t}` to the base
:math:`B` (offsets and the model's own inputs, :func:`svrqp.gap.model.base_design`). Its gain
is the relative drop of the out-of-sample squared error, blocked by group,

.. math::

    g_{c,t} = 1 - \frac{\mathrm{SSE}_{cv}(B + Z_{c,t})}{\mathrm{SSE}_{cv}(B)},

maximised over the time constants :math:`\tau` for ``lag``, and tested against surrogates
(:mod:`svrqp.gap.within.surrogate_tests`). Benjamini–Hochberg runs over all candidate × transform
tests (:data:`ALPHA`); a test counts as evidence only if its adjusted p-value is below
:data:`ALPHA`, its gain is at least :data:`MIN_GAIN` and the RMS it explains,
:math:`\sqrt{g\,\mathrm{SSE}_{cv}(B)/n}`, is at least :data:`MIN_AMPLITUDE` times the noise
level (the smaller of the train reference RMSE and the RMSE left after the candidate).

These models are fitted on the real rows themselves: the evidence says what a per-run
recalibration with the effect would remove (the report's ``p_within`` and ``within_shrink``).
The verdict and the ranking rest on transfer to held-out runs (:mod:`svrqp.gap.transfer.ranking`).
``docs/gap.md`` ("How attribution works") gives the reasons behind each choice. All of it runs only
when asked for (:func:`evidence_within`; ``diagnose(..., within_evidence=True)``).

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
    resampled shrink form the 95 % interval (:func:`estimate_shrink`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.stats import false_discovery_control

from svrqp.gap.contract import ALPHA, MIN_AMPLITUDE, MIN_GAIN, N_BOOTSTRAP
from svrqp.gap.data import CrossValidatedDiscrepancy, GapData, block_bootstrap, block_length
from svrqp.gap.within.surrogate_tests import (
    MAX_SURROGATES,
    SURROGATE_KINDS,
    Bank,
    BetweenRunTest,
    CandidateBank,
    SurrogateTest,
    TestOutcome,
    build_banks,
    check_surrogates,
    run_tests,
)
from svrqp.metrics import rms

__all__ = [  # the step's entry points; the surrogate settings diagnose checks before the work
    "Attribution", "AttributionProblem", "Evidence", "MAX_SURROGATES", "OutOfSampleLosses",
    "SURROGATE_KINDS", "ShrinkEstimate", "attribute", "check_surrogates", "estimate_shrink",
    "evidence_within", "shrink_interval", "within_numbers",
]


def _benjamini_hochberg(p: np.ndarray) -> np.ndarray:
    return false_discovery_control(p, method="bh") < ALPHA


@dataclass(frozen=True)
class AttributionProblem:
    """What every test of a diagnosis shares: the residual, the base, the resampling, the noise.

    Attributes
    ----------
    r : ndarray, shape (n_real,)
        Baseline residual on the real rows.
    B : ndarray, shape (n_real, p)
        Base regressors (with an intercept column).
    folds : list of ndarray
        Blocked cross-validation folds of the real rows.
    groups : ndarray of int
        Group code per real row.
    noise_rmse : float
        Noise level for the absolute floor (the train reference RMSE).
    rng : numpy.random.Generator
        Source of the surrogates.
    surrogates : {"rotation", "continuous"}
        Plain rotations, or rotations made continuous at the seam (module docstring).
    n_jobs : int
        Threads on which the tests of a round score their surrogates (:func:`run_tests`).
    """

    r: np.ndarray
    B: np.ndarray
    folds: list[np.ndarray]
    groups: np.ndarray
    noise_rmse: float
    rng: np.random.Generator
    surrogates: str = "rotation"
    n_jobs: int = 1

    def scorer(self, given: list[np.ndarray] = ()) -> CrossValidatedDiscrepancy:
        """Cross-validated scorer of the residual against the base plus the blocks ``given``."""
        return CrossValidatedDiscrepancy(self.r, np.column_stack([self.B, *given]), self.folds)

    def make_test(
        self, bank: Bank, given: list[np.ndarray] = (),
        scorer: CrossValidatedDiscrepancy | None = None,
    ) -> SurrogateTest | BetweenRunTest:
        """The test of ``bank`` given the blocks ``given``: surrogates within runs, or between runs.

        ``scorer`` (of the same ``given``) may be passed to share it between the tests of a round.
        """
        if isinstance(bank, CandidateBank):
            return SurrogateTest(scorer or self.scorer(given), bank, self.groups, self.rng,
                                 self.surrogates)
        return BetweenRunTest(self.r, np.column_stack([self.B, *given]), self.folds, self.groups,
                              bank)


@dataclass(frozen=True)
class Evidence:
    """A test with its multiplicity-adjusted p-value and floor decision."""

    test: TestOutcome
    q_value: float
    passes: bool
    round: int


def _test_round(
    problem: AttributionProblem, given: list[np.ndarray], banks: list[Bank], round_number: int
) -> list[Evidence]:
    """Test every bank against the base plus ``given``; Benjamini–Hochberg and the effect floor."""
    if not banks:
        return []
    cv = problem.scorer(given)
    tests = run_tests([problem.make_test(bank, given, cv) for bank in banks], MAX_SURROGATES,
                      _benjamini_hochberg, problem.n_jobs)
    q = false_discovery_control([t.p_value for t in tests], method="bh")
    return [
        Evidence(t, float(qi), bool(qi < ALPHA and _above_floor(t, problem.noise_rmse)),
                 round_number)
        for t, qi in zip(tests, q, strict=False)
    ]


def _above_floor(test: TestOutcome, noise_rmse: float) -> bool:
    noise = min(noise_rmse, test.remaining_rmse)
    return test.robust and test.own_gain >= MIN_GAIN and test.explained_rms >= MIN_AMPLITUDE * noise


class OutOfSampleLosses:
    """Out-of-sample errors of the base plus each test's bank, each computed once."""

    def __init__(self, problem: AttributionProblem):
        self.problem = problem
        self._errors: dict[int, np.ndarray] = {}

    def errors(self, test: TestOutcome) -> np.ndarray:
        """Out-of-sample errors of ``r ~ B + bank`` on the real rows (the bank's own nested CV)."""
        p = self.problem
        key = id(test.bank)
        if key not in self._errors:
            self._errors[key] = test.bank.out_of_sample_errors(p.r, p.B, p.folds, p.groups)
        return self._errors[key]


@dataclass
class Attribution:
    """Outcome of the attribution step: the within-real-rows
    evidence of every candidate × transform.

    Attributes
    ----------
    evidence : list of Evidence
        Tests of every candidate × transform (Benjamini–Hochberg, effect floors).
    losses : OutOfSampleLosses
        Their out-of-sample errors on the real rows.
    """

    evidence: list[Evidence]
    losses: OutOfSampleLosses

    def best(self, column: str) -> Evidence:
        """A column's strongest test (passing ones first)."""
        return max((e for e in self.evidence if e.test.column == column),
                   key=lambda e: (e.passes, e.test.gain))


def attribute(problem: AttributionProblem, banks: list[Bank],
              progress: Callable[[str, float], None] = lambda stage, done: None) -> Attribution:
    """Test every candidate transform within the real rows (see the module docstring).

    Parameters
    ----------
    problem : AttributionProblem
        Residual, base, folds, groups, noise level and random source.
    banks : list of CandidateBank or RunLevelBank
        Everything to test (:func:`build_banks`).
    progress : callable
        Called as ``progress(stage, fraction_done)`` when the tests start.

    Returns
    -------
    Attribution
    """
    progress(f"testing {len(banks)} candidate transforms within the real rows", 0.0)
    return Attribution(_test_round(problem, [], banks, 1), OutOfSampleLosses(problem))


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


def shrink_interval(before: np.ndarray, after: np.ndarray, groups: np.ndarray,
                    rng: np.random.Generator) -> tuple[float, float]:
    """95 % moving-block bootstrap interval of ``1 - rmse(after)/rmse(before)``."""
    index = block_bootstrap(groups, N_BOOTSTRAP, block_length(before, groups), rng)
    ss_before = (before**2)[index].sum(axis=1)
    ss_after = (after**2)[index].sum(axis=1)
    shrinks = 1 - np.sqrt(ss_after / np.where(ss_before > 0, ss_before, np.nan))
    low, high = np.nanpercentile(shrinks, [2.5, 97.5])
    return float(low), float(high)


def estimate_shrink(r: np.ndarray, after: np.ndarray, groups: np.ndarray,
                    rng: np.random.Generator) -> ShrinkEstimate:
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


def within_numbers(
    attribution: Attribution,
    r: np.ndarray, groups: np.ndarray, base_rmse: float, rng: np.random.Generator,
) -> dict[str, tuple[float, tuple[float, float], float, float | None]]:
    """Per column: the within-real-rows shrink, its interval,
    its p-value (BH) and its shrink beyond the base (whose out-of-sample RMSE is ``base_rmse``).

    These numbers come from discrepancy models fitted on the real rows themselves: they say
    what a per-run recalibration with the effect would remove, not what the effect buys on a
    new run, and stay under their own keys.
    """
    out = {}
    for column in dict.fromkeys(e.test.column for e in attribution.evidence):
        ev = attribution.best(column)
        estimate = estimate_shrink(r, attribution.losses.errors(ev.test), groups, rng)
        beyond = 1.0 - estimate.rmse_after / base_rmse if base_rmse > 0 else None
        out[column] = (estimate.shrink, (estimate.ci_low, estimate.ci_high), ev.q_value, beyond)
    return out


def evidence_within(problem: AttributionProblem, data: GapData, taus: np.ndarray, base_rmse: float,
                    progress: Callable[[str, float], None] = lambda stage, done: None) -> dict:
    """The within-real-rows evidence of every candidate column, as the causes table carries it.

    Runs :func:`attribute` over every candidate transform
    (:func:`svrqp.gap.within.surrogate_tests.build_banks`) and returns :func:`within_numbers`: per
    column ``(within_shrink, its interval, p_within, shrink_beyond_base)``. Only asked for
    (``diagnose(..., within_evidence=True)``, ``--within-evidence``):
    it never enters a transfer shrink, the verdict or the summary.

    Parameters
    ----------
    problem : AttributionProblem
        Residual, base, folds, groups, noise level and random source (the bootstrap draws from
        the same source after the tests).
    data : GapData
        Prepared rows (the candidates' transforms are built from them).
    taus : ndarray
        Time constants of the ``lag`` transform.
    base_rmse : float
        Out-of-sample real-row RMSE of the per-run recalibration base alone
        (``BaseFit.rmse_after`` of :mod:`svrqp.gap.results.records`; ``shrink_beyond_base`` is
        against it).
    progress : callable
        Called as ``progress(stage, fraction_done)``.

    Returns
    -------
    dict
        Column → ``(shrink, (low, high), q_value, beyond_base)``.
    """
    attribution = attribute(problem, build_banks(data, taus), progress)
    return within_numbers(attribution, problem.r, problem.groups, base_rmse, problem.rng)
