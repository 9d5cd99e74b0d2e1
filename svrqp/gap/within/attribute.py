r"""Which candidate, in which transform, carries information about the real-row residual.

For a candidate :math:`c` and transform :math:`t` (:mod:`svrqp.gap.transfer.candidates`) the
discrepancy model of :mod:`svrqp.gap.data.discrepancy` adds the columns :math:`Z_{c,t}` to the base
:math:`B` (offsets and the model's own inputs, :func:`svrqp.gap.model.recalibration.base_design`). Its gain
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
``docs/gap.md`` ("How attribution works") gives the reasons behind each choice.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.stats import false_discovery_control

from svrqp.gap.contract import ALPHA, MIN_AMPLITUDE, MIN_GAIN
from svrqp.gap.data.discrepancy import CrossValidatedDiscrepancy
from svrqp.gap.transfer.between import RunLevelBank
from svrqp.gap.transfer.candidates import Bank
from svrqp.gap.within.surrogate_tests import (
    MAX_SURROGATES,
    BetweenRunTest,
    SurrogateTest,
    TestOutcome,
    run_tests,
)


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

    def make_test(self, bank: Bank, given: list[np.ndarray] = (),
                  scorer: CrossValidatedDiscrepancy | None = None) -> SurrogateTest | BetweenRunTest:
        """The test of ``bank`` given the blocks ``given``: surrogates within runs, or between runs.

        ``scorer`` (of the same ``given``) may be passed to share it between the tests of a round.
        """
        if isinstance(bank, RunLevelBank):
            return BetweenRunTest(self.r, np.column_stack([self.B, *given]), self.folds, self.groups, bank)
        return SurrogateTest(scorer or self.scorer(given), bank, self.groups, self.rng, self.surrogates)


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
    tests = run_tests([problem.make_test(bank, given, cv) for bank in banks], MAX_SURROGATES, _benjamini_hochberg,
                      problem.n_jobs)
    q = false_discovery_control([t.p_value for t in tests], method="bh")
    return [
        Evidence(t, float(qi), bool(qi < ALPHA and _above_floor(t, problem.noise_rmse)), round_number)
        for t, qi in zip(tests, q)
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
    """Outcome of the attribution step: the within-real-rows evidence of every candidate × transform.

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
        return max((e for e in self.evidence if e.test.column == column), key=lambda e: (e.passes, e.test.gain))


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
