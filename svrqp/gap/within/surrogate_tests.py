r"""Significance of one candidate transform within the real rows, by surrogates.

The statistic of a bank is its best variant's out-of-sample gain over the base discrepancy
model (:mod:`svrqp.gap.within.attribute`). Each surrogate rotates the candidate circularly within
every group by a random offset (:func:`svrqp.gap.data.runs.shift_offsets`, which keeps both
series' autocorrelation and avoids whole periods of a periodic candidate) and recomputes the
gain, :math:`\tau` search included (a lag is filtered again from the rotated candidate,
:class:`LagRecipe`). The Monte-Carlo p-value is sequential
(Besag & Clifford 1991): surrogates are drawn in batches (:data:`SURROGATE_BATCHES`); once
:data:`STOP_EXCEEDANCES` of them reach the observed gain

.. math::

    p = h / S_h \quad (S_h:\ \text{draws up to the } h\text{-th exceedance}),
    \qquad\text{otherwise}\qquad p = \frac{1 + \#\{g_s \ge g\}}{1 + S}.

Further batches are drawn only for tests whose decision is still open (:func:`run_tests`), up
to :data:`MAX_SURROGATES` draws. ``surrogates="continuous"`` (:data:`SURROGATE_KINDS`) lifts the
part that wraps round by the group's end-minus-start change, so every surrogate is continuous
at the seam. A run-level bank is tested between runs instead (:class:`BetweenRunTest`).

The banks tested are built here too (:func:`build_banks`): every candidate × transform as
standardised columns on the real rows (:class:`CandidateBank`, or a run-level candidate's
:class:`svrqp.gap.transfer.between.RunLevelBank`).
``docs/gap.md`` ("How attribution works") gives the reasons and the trade-offs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed

from svrqp.exceptions import ProblemError
from svrqp.gap.contract import EVIDENCE_WITHIN, MIN_RUNS
from svrqp.gap.data import (
    DYNAMIC,
    CrossValidatedDiscrepancy,
    GapData,
    filter_coefficients,
    group_slices,
    lowpass_columns,
    negligible,
    nested_errors,
    rotated_rows,
    shift_offsets,
    standardised,
)
from svrqp.gap.transfer.between import RunLevelBank, between_run_test, is_run_level, run_level_bank

SURROGATE_KINDS = ("rotation", "continuous")
"""Surrogate schemes of the significance tests (module docstring)."""


def check_surrogates(kind: str) -> None:
    """Raise :class:`ProblemError` unless ``kind`` is one of :data:`SURROGATE_KINDS`."""
    if kind not in SURROGATE_KINDS:
        raise ProblemError(f"surrogates must be one of {SURROGATE_KINDS}, got {kind!r}")


SURROGATE_BATCHES = (99, 400, 500, 1000)
"""Surrogates drawn per stage of the sequential test (cumulative 99, 499, 999, 1999)."""

MAX_SURROGATES = sum(SURROGATE_BATCHES)
"""Most surrogates of one test of a round (smallest attainable p-value 1/2000, well below
Benjamini–Hochberg's first threshold ``ALPHA/m`` for the tens of tests of a diagnosis)."""

STOP_EXCEEDANCES = 10
"""A sequential test stops after this many surrogates reach the observed gain."""

_CHUNK_ELEMENTS = 6_000_000
"""Largest surrogate design array (rows × columns) scored at once, to bound memory."""

_TIE_TOLERANCE = 1e-9
"""A surrogate gain this close to the observed one is a tie, and ties count as exceedances: a
column that rotation leaves unchanged (constant within every run) is scored through another
summation order and may come out a few ulps below itself, which must not read as evidence."""


@dataclass(frozen=True)
class TestOutcome:
    r"""Result of one surrogate test.

    Attributes
    ----------
    bank : CandidateBank
        What was tested.
    variant : int
        Index of the best time constant (0 unless ``lag``).
    gain : float
        Observed out-of-sample gain of the best variant.
    gains : ndarray
        Observed gain of every variant.
    p_value : float
        Sequential Monte-Carlo p-value.
    n_surrogates : int
        Surrogates drawn.
    remaining_rmse : float
        Out-of-sample RMSE left with the best variant added.
    own_gain : float
        The gain the effect floors apply to: ``gain``, or for a run-level bank the gain
        beyond its common profile (:mod:`svrqp.gap.transfer.between`).
    explained_rms : float
        RMS of the error the effect itself removes, out of sample.
    robust : bool
        False when a between-run relation rests on one run (:mod:`svrqp.gap.transfer.between`);
        always True for tests within runs.
    """

    bank: Bank
    variant: int
    gain: float
    gains: np.ndarray
    p_value: float
    n_surrogates: int
    remaining_rmse: float
    own_gain: float
    explained_rms: float
    robust: bool = True

    @property
    def column(self) -> str:
        return self.bank.column

    @property
    def transform(self) -> str:
        return self.bank.transform

    @property
    def tau(self) -> float | None:
        return self.bank.tau(self.variant)


class SurrogateTest:
    """Sequential circular-shift surrogate test of one bank against a fitted base.

    Parameters
    ----------
    cv : CrossValidatedDiscrepancy
        Scorer holding the residual, the base and the folds.
    bank : CandidateBank
        Columns to test (all variants; the statistic is the best variant's gain).
    groups : ndarray of int
        Group code per real row.
    rng : numpy.random.Generator
        Source of the shifts.
    surrogates : {"rotation", "continuous"}
        Plain rotations, or rotations lifted at the seam (module docstring).
    """

    def __init__(self, cv: CrossValidatedDiscrepancy, bank: CandidateBank, groups: np.ndarray,
                 rng: np.random.Generator, surrogates: str = "rotation"):
        self.cv, self.bank, self.groups, self.rng = cv, bank, groups, rng
        partner = None if bank.partner is None else bank.partner[:, None]
        self.gains = cv.gain(bank.Z[:, None, :], partner)[0]
        self.variant = int(np.argmax(self.gains))
        self.observed = float(self.gains[self.variant])
        self._signature = bank.Z[:, self.variant] if bank.partner is None else bank.partner
        self._hits = np.zeros(0, dtype=bool)
        check_surrogates(surrogates)
        self._continuous = surrogates == "continuous"
        # the part that wraps round is lifted by its group's end-minus-start change
        if self._continuous:
            slices = group_slices(groups)
            self._first_row = np.concatenate([np.full(sl.stop - sl.start, sl.start)
                                              for sl in slices])
            last = np.concatenate([np.full(sl.stop - sl.start, sl.stop - 1) for sl in slices])
            self._step_Z = bank.Z[last] - bank.Z[self._first_row]
            self._step_partner = None if bank.partner is None else \
                (bank.partner[last] - bank.partner[self._first_row])[:, None]
            self._step_x = None if bank.recipe is None else \
                (bank.recipe.x[last] - bank.recipe.x[self._first_row])[:, None]

    @property
    def drawn(self) -> int:
        """Surrogates drawn so far."""
        return self._hits.size

    @property
    def stopped(self) -> bool:
        """Whether :data:`STOP_EXCEEDANCES` surrogates have reached the observed gain."""
        return int(self._hits.sum()) >= STOP_EXCEEDANCES

    def offsets(self, count: int) -> list[np.ndarray]:
        """The shifts of ``count`` more surrogates, in memory-bounded chunks (this consumes the
        random stream, so tests call it one after another; :meth:`hits` may run in parallel)."""
        n, v = self.bank.Z.shape
        chunk = max(1, _CHUNK_ELEMENTS // (n * v))
        return [shift_offsets(self.groups, min(chunk, count - start), self.rng, self._signature)
                for start in range(0, count, chunk)]

    def hits(self, offsets: np.ndarray) -> np.ndarray:
        """Whether each surrogate shifted by ``offsets`` (one chunk of :meth:`offsets`) reaches the
        observed gain. Reads the test and changes nothing, so chunks may be scored in parallel."""
        rows = rotated_rows(self.groups, offsets).T  # surrogate s reads rows[:, s]
        partner = None if self.bank.partner is None else self.bank.partner[rows]
        recipe = self.bank.recipe
        x = None if recipe is None else recipe.x[rows]
        Z = self.bank.Z[rows] if recipe is None else None
        if self._continuous:
            wrapped = rows < rows[self._first_row]  # read from before the group's rotation point
            if recipe is None:
                Z = Z + wrapped[:, :, None] * self._step_Z[:, None, :]
            else:
                x = x + wrapped * self._step_x
            partner = None if partner is None else partner + wrapped * self._step_partner
        if recipe is not None:  # filter the rotated candidate again (see LagRecipe)
            Z = recipe.own(x)
        return self.cv.gain(Z, partner).max(axis=1) >= self.observed - _TIE_TOLERANCE

    def record(self, hits: list[np.ndarray]) -> None:
        """Add the :meth:`hits` of further surrogates, in the order they were drawn."""
        self._hits = np.concatenate([self._hits, *hits])

    @property
    def p_value(self) -> float:
        """Besag–Clifford p-value: ``h/S_h`` once stopped, else ``(1 + hits)/(1 + drawn)``."""
        if self.stopped:
            return STOP_EXCEEDANCES / (int(np.flatnonzero(self._hits)[STOP_EXCEEDANCES - 1]) + 1)
        return (1 + int(self._hits.sum())) / (1 + self.drawn)

    def outcome(self) -> TestOutcome:
        """The test's result."""
        # A near-perfect fit can leave a gain a rounding
        # error above 1 (the SSE is a difference of sums).
        remaining = float(np.sqrt(self.cv.sse_base * max(1 - self.observed, 0.0) / self.cv.n))
        explained = float(np.sqrt(max(self.observed, 0.0) * self.cv.sse_base / self.cv.n))
        return TestOutcome(self.bank, self.variant, self.observed, self.gains, self.p_value,
                           self.drawn, remaining, self.observed, explained)


class BetweenRunTest:
    """The between-run test of a run-level bank
    (:func:`svrqp.gap.transfer.between.between_run_test`).

    It draws no surrogates; it has the interface of :class:`SurrogateTest` so that
    :func:`run_tests` treats both alike (it is decided at once).

    Parameters
    ----------
    r : ndarray, shape (n,)
        Residual on the real rows.
    base : ndarray, shape (n, p)
        Base regressors and the blocks already accepted.
    folds : list of ndarray
        Blocked cross-validation folds (whole runs, with enough of them).
    groups : ndarray of int
        Run code per real row.
    bank : RunLevelBank
        The candidate.
    """

    drawn = 0
    stopped = True

    def __init__(self, r: np.ndarray, base: np.ndarray, folds: list[np.ndarray], groups: np.ndarray,
                 bank: RunLevelBank):
        self.bank = bank
        sse_base = CrossValidatedDiscrepancy(r, base, folds).sse_base
        sse_profile = CrossValidatedDiscrepancy(r, np.column_stack([base, bank.profile]),
                                                folds).sse_base
        self.sse = CrossValidatedDiscrepancy(r, np.column_stack([base, bank.block()]),
                                             folds).sse_base
        self.n = len(r)
        # Ranked by what the candidate adds beyond the common profile (which is no candidate's),
        # as a share of the base's error like every other bank's gain.
        self.gain = (sse_profile - self.sse) / sse_base if sse_base > 0 else 0.0
        self.own_gain = 1.0 - self.sse / sse_profile if sse_profile > 0 else 0.0
        self.explained = float(np.sqrt(max(sse_profile - self.sse, 0.0) / self.n))
        result = between_run_test(r, base, groups, bank)
        self.p_value, self.robust = result.p_value, result.robust

    def offsets(self, count: int) -> list[np.ndarray]:
        """No surrogates: the test is parametric."""
        return []

    def record(self, hits: list[np.ndarray]) -> None:
        """Nothing to record: the test is parametric."""

    def outcome(self) -> TestOutcome:
        """The test's result."""
        return TestOutcome(self.bank, 0, self.gain, np.array([self.gain]), self.p_value, 0,
                           float(np.sqrt(self.sse / self.n)), self.own_gain, self.explained,
                           self.robust)


def run_tests(
    tests: list[SurrogateTest], most: int, decided: Callable[[np.ndarray], np.ndarray],
    n_jobs: int = 1
) -> list[TestOutcome]:
    """Draw surrogates batch by batch for the tests whose decision is still open.

    A test closes when it stops (Besag–Clifford), reaches ``most`` draws, or is rejected by
    ``decided`` (applied to all current p-values) — a p-value computed after a fixed number of
    draws is valid whatever happens later, so a test rejected at a coarse resolution needs no
    finer one.

    The shifts of a batch are drawn test after test from the one random stream; the chunks of
    surrogates of every open test are then scored on ``n_jobs`` threads (joblib; NumPy and SciPy
    release the GIL in this work) and recorded in the order drawn, so the result does not depend
    on ``n_jobs``.
    """
    rejected = np.zeros(len(tests), dtype=bool)
    with Parallel(n_jobs=n_jobs, backend="threading") as parallel:
        for batch in SURROGATE_BATCHES:
            open_tests = [t
                          for t, done in zip(tests, rejected,
                                      strict=False) if not done and not t.stopped
                          and t.drawn < most]
            if not open_tests:
                break
            work = [
                (test, chunk)
                for test in open_tests
                for chunk in test.offsets(min(batch, most - test.drawn))
            ]
            hits = parallel(delayed(test.hits)(chunk) for test, chunk in work)
            for test in open_tests:
                test.record([h for (owner, _), h in zip(work, hits, strict=False) if owner is test])
            rejected = decided(np.array([t.p_value for t in tests]))
    return [t.outcome() for t in tests]


@dataclass(frozen=True)
class LagRecipe:
    r"""How a ``lag`` bank's own columns are computed from the candidate, for its surrogates.

    A lag carries memory: the filter starts in equilibrium with a run's first value, so a
    noisy reading gives every run a transient from its first sample. Rotating the *filtered*
    column would move that transient into the middle of the run, where it breaks the
    surrogate's smoothness and makes the observed column fit a smooth residual better than
    any surrogate. The surrogates therefore rotate the candidate itself and filter it again.

    Attributes
    ----------
    x : ndarray, shape (n_real,)
        The candidate on the real rows.
    alpha : ndarray, shape (n_real, v)
        Filter coefficients (:func:`svrqp.gap.data.transforms.filter_coefficients`), restarting
        at each real group's first row.
    centre, scale : ndarray, shape (v,)
        Standardisation of the observed columns :math:`\ell_\tau`, applied to surrogates alike.
    """

    x: np.ndarray
    alpha: np.ndarray
    centre: np.ndarray
    scale: np.ndarray

    @classmethod
    def of(cls, x: np.ndarray, t: np.ndarray, groups: np.ndarray, taus: np.ndarray) -> LagRecipe:
        """The recipe of candidate values ``x`` on the
        real rows (order ``t``, groups ``groups``)."""
        alpha = filter_coefficients(t, groups, taus)
        ell = lowpass_columns(x[:, None], alpha)[:, 0, :] - x[:, None]
        centre = ell.mean(axis=0)
        scale = ell.std(axis=0)
        return cls(x, alpha, centre, np.where(negligible(scale, ell), np.inf, scale))

    def own(self, X: np.ndarray) -> np.ndarray:
        r"""Standardised :math:`\ell_\tau` of the series ``X`` (n, s): shape (n, s, v)."""
        out = lowpass_columns(X, self.alpha)
        out -= X[:, :, None]  # in place: for long records these arrays hold millions of values
        out -= self.centre
        out /= self.scale
        return out


@dataclass(frozen=True)
class CandidateBank:
    """Standardised columns of one candidate transform on the real rows.

    Attributes
    ----------
    column : str
        Candidate column.
    transform : str
        ``"level"``, ``"rate"`` or ``"lag"``.
    taus : ndarray or None
        Time constant of each variant (``lag``), else None.
    Z : ndarray, shape (n_real, v)
        Own column of each of the ``v`` variants (time constants).
    partner : ndarray, shape (n_real,) or None
        Column every variant also holds (the level :math:`x` in ``lag`` of an unmodelled
        candidate), else None.
    recipe : LagRecipe or None
        For ``lag``: how surrogates recompute ``Z`` from the rotated candidate.
    """

    column: str
    transform: str
    taus: np.ndarray | None
    Z: np.ndarray
    partner: np.ndarray | None = None
    recipe: LagRecipe | None = None
    evidence: str = EVIDENCE_WITHIN

    def block(self, variant: int) -> np.ndarray:
        """Columns of one variant, shape (n_real, k)."""
        own = self.Z[:, variant : variant + 1]
        return own if self.partner is None else np.column_stack([self.partner, own])

    def tau(self, variant: int) -> float | None:
        """Time constant of a variant (None unless ``lag``)."""
        return None if self.taus is None else float(self.taus[variant])

    def out_of_sample_errors(self, r: np.ndarray, B: np.ndarray, folds: list[np.ndarray],
                             groups: np.ndarray) -> np.ndarray:
        """Errors of ``r ~ B + block`` on the real rows,
        the variant chosen inside each fold (nested CV)."""
        return nested_errors(r, B, self.Z, self.partner, folds, groups)


Bank = CandidateBank | RunLevelBank
"""Anything :func:`attribute` tests: a candidate transform, or a run-level candidate's level."""


def build_banks(data: GapData, taus: np.ndarray) -> list[Bank]:
    """Every candidate × transform bank to be tested, standardised on the real rows.

    With at least :data:`svrqp.gap.contract.MIN_RUNS` real runs, a run-level candidate
    (:func:`svrqp.gap.transfer.between.is_run_level`) that is not a model feature also gets a bank
    of its level tested between runs. Its transforms are tested within runs as well: a
    temperature whose level differs by season between runs can still carry the effect's
    dynamics within each of them.
    """
    real = data.is_real
    groups = data.groups[real]
    between = len(group_slices(groups)) >= MIN_RUNS
    banks: list[Bank] = []
    for j, column in enumerate(data.candidates):
        x = data.C[real, j]
        if between and column not in data.features and is_run_level(x, groups):
            banks.append(run_level_bank(column, x, data.t[real], groups))
        partner = None if column in data.features else standardised(x[:, None])[0][:, 0]
        if column not in data.features:
            banks.append(CandidateBank(column, "level", None, partner[:, None]))
        for name, dynamic in DYNAMIC.items():
            banks.append(CandidateBank(column, name, None,
                                       standardised(dynamic(x, data.t[real], groups)[:, None])[0]))
        # The lag restarts at each real group's first row, exactly as its surrogates do.
        recipe = LagRecipe.of(x, data.t[real], groups, taus)
        banks.append(CandidateBank(column, "lag", taus, recipe.own(x[:, None])[:, 0, :], partner,
                                   recipe))
    return banks
