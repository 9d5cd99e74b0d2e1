r"""Causes ranked by what they buy on held-out runs, and tested against surrogates.

Every candidate × transform is refitted leave-one-unit-out with the model family
(:mod:`svrqp.gap.transfer.linear`); a column's row in the causes table is its best-transferring
transform (fewer parameters within :data:`SAME_FIT`). Its *transfer gain* is

.. math::

    g = 1 - \frac{\mathrm{SSE}_\mathrm{after}}{\mathrm{SSE}_\mathrm{refit}}
      = 1 - (1 - \mathrm{shrink\_beyond\_refit})^2 .

Significance by surrogates that respect what varies where
    Under "this candidate carries nothing", where its values fall does not matter. A
    candidate that varies within runs is rotated circularly within every group
    (:func:`svrqp.gap.data.runs.shift_offsets`, which keeps its autocorrelation); one that holds
    a level per run (:func:`svrqp.gap.transfer.between.is_run_level`) has its run levels permuted
    across the runs. Such a candidate's ``level`` is refitted two ways: as the block of
    :mod:`svrqp.gap.transfer.between` (a profile along the run that it scales, :attr:`Effect.block`)
    and as the plain column (an offset in proportion to it, one parameter: with two or three
    held-out runs the block's seven columns extrapolate where the plain level transfers); the
    column's row is the better of the two (the plain one on a near tie). Its ``rate`` and ``lag``
    are refitted too unless it is constant within every run (a reading that holds the season's level
    through a run may still follow an effect's dynamics within it), and rotated within runs like any
    other candidate's.

    The surrogates themselves (:mod:`svrqp.gap.transfer.surrogates`) rotate only the part of a
    candidate that the family's other inputs do not explain: a plain rotation would also break its
    relation to the inputs, and the transfer gain of a column collinear with them spreads much wider
    than that of its rotations (on one record made exactly linear in the inputs plus AR(1) noise,
    plain rotations named a column in 11 of 260 noise draws, this scheme in 5, each time the drive
    input ``axis_duty_pct``, which the temperatures do not explain).

    Each surrogate is transformed again (a lag filtered again) and refitted exactly as the
    observed one, :math:`\tau` chosen inside each fit. (Its gain is not its best over the
    column's transforms, although the observed one was chosen among them: on FL_THERMAL that
    cost verdicts the independent checker confirms, top-3 hit 0.95 → 0.85.) The Monte-Carlo p-value
    is sequential (Besag & Clifford 1991; at most :data:`MAX_SURROGATES` draws in
    :data:`SURROGATE_STAGES`, stopping after :data:`STOP_EXCEEDANCES` exceedances or once
    rejected). The :data:`MAX_TESTED` best causes above the effect floor are tested;
    Benjamini–Hochberg runs over every column (an untested one counts with :math:`p = 1`),
    level :data:`svrqp.gap.contract.ALPHA`.

Exact permutation tests for few runs
    Over :math:`k` runs a run-level candidate has only :math:`k!` orderings of its levels. When
    :math:`k! \le` :data:`EXACT_ORDERINGS` every ordering is refitted and the p-value is exact,
    :math:`p = \#\{\pi : g_\pi \ge g\} / k!` (the observed ordering included), instead of a
    Monte-Carlo estimate of it. Its smallest reachable value is :math:`p_{\min} = s / k!`, with
    :math:`s` the orderings that leave the run levels as they are (one, unless two runs share a
    level). When even :math:`p_{\min}`, put in place of the candidate's p-value, leaves its
    Benjamini–Hochberg q-value at or above :math:`\alpha` — with three runs in all
    :math:`p_{\min} = 1/6` — no data could have made it significant: if it is the
    best-transferring cause, the verdict's reason and the summary say that the evidence is too
    thin (:attr:`Ranking.too_thin`) instead of only "not beyond chance". The ``local`` form of such
    a candidate is never tested or ranked (:mod:`svrqp.gap.transfer.windows`), but it is refitted:
    when it transfers better than every ranked cause, beyond its window alone and beyond the
    column's global forms, it is the best-transferring
    cause of that sentence, which names its window.

    When :func:`svrqp.gap.transfer.windows.permutations_can_reject` says that no ordering of the
    runs can reach Benjamini–Hochberg's first threshold, and the column's best transform rotated
    within runs (``rate`` or ``lag``) clears the effect floor, that transform's rotation test stands
    for the column (:attr:`Ranked.tested_by`): under "the column carries nothing" it is as valid a
    test as the permutation, and it can decide. The column's row keeps its best-transferring
    transform and its numbers.

A t-test between runs where no ordering can decide
    From :data:`svrqp.gap.transfer.between.PARAMETRIC_MIN_RUNS` real runs on, the orderings are
    no longer the binding limit on the evidence, only on the permutation test: five runs give
    120 orderings, and nine runs at two loads only 126 distinct ones
    (:func:`svrqp.gap.transfer.between.permutation_floor`). When that floor stays above
    Benjamini–Hochberg's first threshold :math:`\alpha/m`, a run-level cause's p-value is the
    t-test of :func:`svrqp.gap.transfer.between.between_run_test` instead (the family's residual
    summarised per run, regressed on the candidate's run level; one run must not carry it), and its
    note says so. Its size is measured by ``benchmarks/gap_run_level_size.py``.

Effect floor
    A cause is significant only if its transfer gain is at least
    :data:`svrqp.gap.contract.MIN_GAIN`.

Stronger causes that cannot be tested
    A run-level cause that transfers better than the verdict candidate but cannot be tested (fewer
    than :data:`svrqp.gap.contract.MIN_RUNS` real runs to permute) is conditioned on: the candidate
    stands only if it adds beyond it, else no verdict is named.

Confounded pairs
    A rival whose gain reaches :data:`RIVAL_FRACTION` of the top cause's is checked by
    conditional tests both ways: the gain of one with the other already in the family's
    inputs, against surrogates of the one tested. The top cause stays if it adds beyond the
    rival; a rival that adds beyond it while it adds nothing beyond the rival takes over; when
    neither adds, the two cannot be told apart and both are named (``ambiguous_with``).
"""

from __future__ import annotations

import numpy as np
from scipy.stats import false_discovery_control

from svrqp.gap.contract import ALPHA, MIN_GAIN, MIN_RUNS
from svrqp.gap.data import (
    DYNAMIC,
    RISE,
    TRANSFORMS as CANDIDATE_TRANSFORMS,
    WITHIN_RUN,
    GapData,
    filter_coefficients,
    group_slices,
    lag,
    lowpass_columns,
)
from svrqp.gap.results.records import Effect, Ranked, Ranking, TransferFit
from svrqp.gap.transfer.between import (
    PARAMETRIC_MIN_RUNS,
    between_run_test,
    is_run_level,
    moves_beyond_noise,
    permutation_floor,
    run_level_bank,
    run_level_columns,
    varies_within,
)
from svrqp.gap.transfer.linear import LinearTransfer, shrink_of_gain
from svrqp.gap.transfer.surrogates import TransferSurrogates, besag_clifford_p
from svrqp.gap.transfer.windows import (
    LOCAL_MARGIN,
    WindowAlone,
    chosen_region,
    confined_reason,
    confined_to,
    local_columns,
    local_note,
    permutations_can_reject,
    region_text,
    window_axes,
)
from svrqp.units import probability_relation

TRANSFORMS = (*CANDIDATE_TRANSFORMS, "local")
"""Transforms refitted for every candidate (a model feature: no ``level`` and no ``rise``; a
run-level candidate: ``level`` and ``local`` only; ``local``: :mod:`svrqp.gap.transfer.windows`)."""

SAME_FIT = 0.005
"""Two transforms of one column whose shrinks differ by less than this count as the same fit."""

SURROGATE_STAGES = (19, 80, 200, 300, 400)
"""Surrogates drawn per stage of a transfer test (cumulative 19, 99, 299, 599, 999)."""

MAX_SURROGATES = sum(SURROGATE_STAGES)
"""Most surrogates of one transfer test (smallest p-value 1/1000, below Benjamini–Hochberg's
first threshold for the tens of columns of a diagnosis)."""

STOP_EXCEEDANCES = 10
"""A sequential test stops after this many surrogates reach the observed gain."""

MAX_TESTED = 5
"""Causes tested against surrogates, best transfer gain first."""

RIVAL_FRACTION = 0.5
"""A significant cause whose gain reaches this fraction of the top one's is a rival."""

LAG_BATCH = 20
"""Surrogates whose lags are filtered as one batch."""

PARAMETRIC_NOTE = ("tested between its {runs} run levels by a t-test (svrqp.gap.transfer.between): "
                   "no ordering of them could reach significance")
"""The note of a run-level cause whose p-value is the t-test's rather than a permutation's."""

CONDITIONAL_SURROGATES = 99
"""Surrogates of a conditional test."""


class TransferRanker:
    """Refits every candidate transform leave-one-unit-out and tests the best (module docstring).

    Parameters
    ----------
    data : GapData
        Prepared rows.
    family : LinearTransfer
        The family's refits.
    taus : ndarray
        The time-constant grid.
    rng : numpy.random.Generator
        Source of the surrogates (the ``local`` form's from a stream spawned from it, which
        leaves this one's draws to the other transforms).
    local : bool
        Whether the ``local`` form is refitted (:mod:`svrqp.gap.transfer.windows`): in windows of
        the order axis, and of every ``data.along`` column.
    """

    def __init__(self, data: GapData, family: LinearTransfer, taus: np.ndarray,
                 rng: np.random.Generator, local: bool = False):
        self.data, self.family, self.taus, self.rng = data, family, taus, rng
        self.local_rng = rng.spawn(1)[0]
        self.refit = family.refit()
        self.sse_refit = float(self.refit.errors @ self.refit.errors)
        self.axes = window_axes(data, family.units.code) if local else {}
        self.window_alone = WindowAlone(family, self.axes)
        # One record in blocks: its readings, rotated plainly, would jump at the seam.
        self.surrogates = TransferSurrogates(data, family.A, rng, self.local_rng,
                                             lift=family.units.kind == "blocks")
        # Whether some ordering of the run levels can reach
        # Benjamini–Hochberg's first threshold at all.
        self.permutable = permutations_can_reject(len(group_slices(data.groups)),
                                                  len(data.candidates), ALPHA)
        self.unpermutable: list[Ranked] = []
        """The refitted :meth:`untestable_form` rows of the candidates (not model features), best
        first (set by :meth:`rank`)."""

    # -- effects ------------------------------------------------------------------------

    def effects(self) -> list[Effect]:
        """Every candidate × transform to refit."""
        data, real = self.data, self.data.is_real
        out = []
        for j, column in enumerate(data.candidates):
            run_level = (len(group_slices(data.groups[real])) >= 2
                         and is_run_level(data.C[real, j], data.groups[real]))
            moves = varies_within(data.C[:, j], data.groups)
            drifts = run_level and moves_beyond_noise(data.C[real, j], data.groups[real])
            for transform in TRANSFORMS:
                if transform in ("level", RISE) and column in data.features:
                    continue
                if run_level and transform in WITHIN_RUN and not moves:
                    continue  # its rate, rise and lag are zero
                if transform == "local":  # a drifting level is rotated within runs here too
                    out += [Effect(column, transform, None, run_level and not drifts,
                                   windows=windows, axis=axis)
                            for axis, (_, windows) in self.axes.items() if len(windows)]
                    continue
                if run_level and transform == "level":  # a level scaling a profile, or an offset
                    out.append(Effect(column, transform, None, run_level, block=True))
                # Rotated within runs: the dynamics, and a level that moves within runs beyond its
                # reading noise (the block's test still exchanges its run levels).
                within = transform in WITHIN_RUN or (transform == "level" and drifts)
                out.append(Effect(column, transform, self.taus if transform == "lag" else None,
                                  run_level and not within))
        return out

    def untestable_form(self, effect: Effect) -> bool:
        """The ``local`` form of a run-level candidate whose run levels are too few to permute to
        significance: refitted, never tested or ranked; it only says why a
        diagnosis names nothing (:meth:`thin_evidence`)."""
        return effect.windows is not None and effect.run_level and not self.permutable

    def columns(self, effect: Effect, x: np.ndarray | None = None,
                ell: np.ndarray | None = None) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
        """The effect's columns on every row (``x``: the candidate, or a surrogate of it), its
        variants and the rows where it is known (``ell``: its lag columns on the known rows, when
        already filtered — :meth:`lags` filters a batch of surrogates at once)."""
        data = self.data
        x = data.C[:, data.candidates.index(effect.column)] if x is None else x
        known = np.isfinite(x)
        t, groups, xk = data.t[known], data.groups[known], x[known]
        if effect.block:  # its level scales a profile along each run
            own = run_level_columns(xk, t, groups)
            variants = [np.arange(own.shape[1])]
        elif effect.transform == "level":
            own = xk[:, None]
            variants = [np.array([0])]
        elif effect.transform in DYNAMIC:
            own = DYNAMIC[effect.transform](xk, t, groups)[:, None]
            variants = [np.array([0])]
        elif effect.transform == "local":
            own, variants = local_columns(xk, self.axes[effect.axis][0][known], effect.windows)
        else:
            ell = lag(xk, t, groups, effect.taus) if ell is None else ell
            if effect.column in data.features:
                own, variants = ell, [np.array([j]) for j in range(ell.shape[1])]
            else:
                own, variants = (np.column_stack([xk, ell]),
                                 [np.array([0, 1 + j]) for j in range(ell.shape[1])])
        E = np.full((x.size, own.shape[1]), np.nan)
        E[known] = own
        return E, variants, known

    def lags(self, effect: Effect, xs: list[np.ndarray]) -> list[np.ndarray | None]:
        """The lag columns of each series in ``xs`` on its known
        rows, filtered as one batch (None unless ``lag``)."""
        if effect.transform != "lag" or not xs:
            return [None] * len(xs)
        known = np.isfinite(xs[0])
        X = np.column_stack([x[known] for x in xs])
        alpha = filter_coefficients(self.data.t[known], self.data.groups[known], effect.taus)
        ell = lowpass_columns(X, alpha) - X[:, :, None]
        return [ell[:, s, :] for s in range(len(xs))]

    def fit(self, effect: Effect, x: np.ndarray | None = None, given: np.ndarray | None = None,
            ell: np.ndarray | None = None) -> TransferFit:
        """Leave-one-unit-out errors with the effect (and the columns ``given``) added."""
        E, variants, known = self.columns(effect, x, ell)
        if given is not None:
            k = given.shape[1]
            variants = [np.concatenate([np.arange(k), k + v]) for v in variants]
            E = np.column_stack([given, E])
            known = known & np.isfinite(given).all(axis=1)
        return self.family.errors(E, variants, known)

    def gain(self, fit: TransferFit, reference: float | None = None) -> float:
        """Transfer gain of a fit against the refit (or against ``reference``, an SSE)."""
        base = self.sse_refit if reference is None else reference
        return 1.0 - float(fit.errors @ fit.errors) / base if base > 0 else 0.0

    # -- ranking ------------------------------------------------------------------------

    def rank(self) -> list[Ranked]:
        """One row per column, its best-transferring transform, best first."""
        best: dict[str, Ranked] = {}
        rotated: dict[str, Ranked] = {}
        untestable: list[Ranked] = []
        for effect in self.effects():
            fit = self.fit(effect)
            row = Ranked(effect, fit, self.gain(fit), tau=effect.chosen_tau(fit.variant),
                         region=self._region(effect, fit))
            if effect.windows is not None:  # what the candidate buys beyond its window's own offset
                row.beyond_window = self.gain(
                    fit, self.window_alone.sse(effect.axis, self.columns(effect)[2]))
            if self.untestable_form(effect):
                if effect.column not in self.data.features:
                    untestable.append(row)
                continue
            held = best.get(effect.column)
            if held is None or _better(row, held):
                best[effect.column] = row
            if not effect.run_level and effect.windows is None:
                held = rotated.get(effect.column)
                if held is None or _better(row, held):
                    rotated[effect.column] = row
        if not self.permutable:
            for column, row in best.items():
                alt = rotated.get(column)
                if row.effect.run_level and alt is not None and alt.gain >= MIN_GAIN:
                    row.tested_by = alt
        for row in best.values():
            # the window it chose most: collinear with the design, or no better alone
            if row.region is not None:
                E, _, known = self.columns(row.fixed_effect())
                row.note = local_note(self.family.A[known], E[known], row.beyond_window, MIN_GAIN)
        self.unpermutable = sorted(untestable, key=lambda r: -r.gain)
        return sorted(best.values(), key=lambda r: -r.gain)

    def _region(self, effect: Effect, fit: TransferFit) -> dict | None:
        return None if effect.windows is None else chosen_region(effect.windows, effect.axis,
                                                                 fit.variant)

    # -- surrogates ---------------------------------------------------------------------

    def draw(self, effect: Effect, observed: float, count: int, given: np.ndarray | None = None,
             reference: float | None = None) -> list[bool]:
        """Whether each of ``count`` surrogates reaches the observed gain (stopping at the
        :data:`STOP_EXCEEDANCES`-th that does)."""
        hits: list[bool] = []
        surrogates = self.surrogates.surrogate(effect, count)
        for start in range(0, count, LAG_BATCH):
            batch = surrogates[start:start + LAG_BATCH]
            for xs, ell in zip(batch, self.lags(effect, batch), strict=False):
                hits.append(self.gain(self.fit(effect, xs, given, ell),
                                      reference) >= observed - 1e-12)
                if sum(hits) >= STOP_EXCEEDANCES:
                    return hits
        return hits

    def exact_p(self, effect: Effect, observed: float, orders: list[np.ndarray],
                given: np.ndarray | None = None, reference: float | None = None) -> float:
        """Exact permutation p-value over every ordering
        of the run levels (the observed one included)."""
        surrogates = self.surrogates.surrogate(effect, len(orders), orders)
        hits = sum(self.gain(self.fit(effect, xs, given),
                             reference) >= observed - 1e-12 for xs in surrogates)
        return hits / len(orders)

    def p_value(self, effect: Effect, observed: float, most: int, given: np.ndarray | None = None,
                reference: float | None = None) -> float:
        """Sequential Monte-Carlo p-value of one transfer gain, at most ``most`` surrogates (exact
        for a run-level candidate over few runs, :meth:`exact_p`)."""
        orders = self.surrogates.orderings(effect)
        if orders is not None:
            return self.exact_p(effect, observed, orders, given, reference)
        hits = self.draw(effect, observed, min(SURROGATE_STAGES[0], most), given, reference)
        if sum(hits) < STOP_EXCEEDANCES // 2:  # not clearly null after the first stage
            hits += self.draw(effect, observed, most - len(hits), given, reference)
        return besag_clifford_p(hits, STOP_EXCEEDANCES)

    def test(self, ranked: list[Ranked]) -> None:
        """Surrogate p-values of the best causes above the floor, then Benjamini–Hochberg over all.

        Surrogates are drawn in :data:`SURROGATE_STAGES`; a test stops when it reaches
        :data:`STOP_EXCEEDANCES` exceedances, when Benjamini–Hochberg over every column already
        rejects it (a p-value after a fixed number of draws stays valid), or at the last stage.
        """
        tested = [r for r in ranked if r.above_floor][:MAX_TESTED]
        sampled = []
        for row in tested:
            if self.parametric(row.effect, len(ranked)):
                row.p_raw, row.tested = self.between_p(row.effect), True
                row.note = row.note or PARAMETRIC_NOTE.format(runs=self.n_real_runs)
                continue
            orders = self.surrogates.orderings(row.effect)
            if orders is None or row.tested_by is not None:
                sampled.append(row)
            else:
                row.p_raw, row.tested = self.exact_p(row.effect, row.gain, orders), True
        self._adjust(ranked)
        tested = sampled
        hits: dict[int, list[bool]] = {id(r): [] for r in tested}
        for stage in SURROGATE_STAGES:
            open_rows = [r for r in tested if sum(hits[id(r)]) < STOP_EXCEEDANCES
                         and not r.significant]
            if not open_rows:
                break
            for row in open_rows:
                test = row.tested_by or row
                hits[id(row)] += self.draw(test.effect, test.gain, stage)
                row.p_raw, row.tested = besag_clifford_p(hits[id(row)], STOP_EXCEEDANCES), True
            self._adjust(ranked)

    @property
    def n_real_runs(self) -> int:
        """Real runs (or blocks) of the diagnosis."""
        return len(group_slices(self.data.groups[self.data.is_real]))

    def parametric(self, effect: Effect, n_columns: int) -> bool:
        """Whether a run-level effect is tested by the t-test between runs: at least
        :data:`~svrqp.gap.transfer.between.PARAMETRIC_MIN_RUNS` runs whose levels are permuted
        (train and real), :data:`svrqp.gap.contract.MIN_RUNS` of them real (the t-test's
        observations), and orderings that cannot reach Benjamini–Hochberg's first threshold over
        ``n_columns`` (ties between run levels included)."""
        if not effect.run_level or effect.windows is not None or self.n_real_runs < MIN_RUNS:
            return False
        levels = self.surrogates.run_levels(effect)
        return levels.size >= PARAMETRIC_MIN_RUNS and permutation_floor(levels) > ALPHA / n_columns

    def between_p(self, effect: Effect) -> float:
        """The p-value of :func:`~svrqp.gap.transfer.between.between_run_test` for a run-level
        effect: the run summaries of the family's residual on the real rows against the candidate's
        run levels, given the family's inputs; 1 when the
        relation rests on one run (not ``robust``)."""
        data, family, real = self.data, self.family, self.data.is_real
        residual = family.y - family.A @ np.linalg.lstsq(family.A, family.y, rcond=None)[0]
        x = data.C[:, data.candidates.index(effect.column)]
        bank = run_level_bank(effect.column, x[real], data.t[real], data.groups[real])
        result = between_run_test(residual[real], family.A[real], data.groups[real], bank)
        return result.p_value if result.robust else 1.0

    def _adjust(self, ranked: list[Ranked]) -> None:
        """Benjamini–Hochberg over every column (an untested one counts with p = 1)."""
        if ranked:
            q = false_discovery_control([r.p_raw for r in ranked], method="bh")
            for row, qi in zip(ranked, q, strict=False):
                row.q_value = float(qi)

    def adds(self, a: Ranked, b: Ranked) -> bool:
        """Whether ``a`` carries transfer information beyond ``b`` (conditional test).

        Both enter with the time constant their fits chose most (:attr:`Ranked.tau`): a second
        free time constant would let two readings of one source "add" a two-pole filter.
        """
        effect = a.fixed_effect()
        observed, given, reference = self.given(effect, b)
        if observed < MIN_GAIN:
            return False
        return self.p_value(effect, observed, CONDITIONAL_SURROGATES, given, reference) < ALPHA

    def given(self, effect: Effect, b: Ranked) -> tuple[float, np.ndarray, float]:
        """``effect``'s gain with ``b`` (fixed) in the family's inputs, ``b``'s columns, the SSE."""
        given, _, known = self.columns(b.fixed_effect())
        base = self.family.errors(given, [np.arange(given.shape[1])], known)
        reference = float(base.errors @ base.errors)
        return self.gain(self.fit(effect, given=given), reference), given, reference

    def choose(self, ranked: list[Ranked]) -> Ranking:
        """The verdict candidate among the significant causes, confounded rivals checked; one
        confined to a stretch is withheld (:func:`svrqp.gap.transfer.windows.confined_to`)."""
        result = Ranking(ranked)
        significant = [r for r in ranked if r.significant]
        self.thin_evidence(ranked, result)
        if not significant:
            return result
        top = significant[0]
        for rival in [r for r in significant[1:] if r.gain >= RIVAL_FRACTION * top.gain]:
            a_beyond, b_beyond = self.adds(top, rival), self.adds(rival, top)
            if b_beyond and not a_beyond:
                top.note = f"explained by {rival.effect.column} on held-out runs"
                result.notes.append(f"{rival.effect.column} explains {top.effect.column} away")
                top = rival
            elif not a_beyond and not b_beyond:
                rival.ambiguous = True
                rival.note = f"cannot be told apart from {top.effect.column} on held-out runs"
                result.ambiguous_with.append(rival.effect.column)
            elif a_beyond and not b_beyond:
                rival.note = f"explained by {top.effect.column} on held-out runs"
            else:
                rival.note = f"carries information beyond {top.effect.column}"
        top.ambiguous = bool(result.ambiguous_with)
        stronger = self.stronger_unproven(ranked, top)
        if stronger is not None:
            top.note = f"adds nothing beyond {stronger.effect.column} on held-out runs"
            n_real = len(group_slices(self.data.groups[self.data.is_real]))
            untested = (f"is not significant between {n_real} real runs (q "
                        f"{probability_relation(stronger.q_value)})" if stronger.tested
                        else f"cannot be tested between {MIN_RUNS - 1} or fewer real runs")
            result.withheld = (
                f"The {top.effect.transform} of {top.effect.column} passes the transfer test, but "
                f"the {stronger.effect.transform} of {stronger.effect.column} transfers better and "
                f"it adds nothing beyond it on held-out runs, while {stronger.effect.column}, one "
                f"level per run, {untested}: no cause is named.")
            return result
        stretch = confined_to(self.family, self.data, top.effect, self.refit, top.fit)
        if stretch is not None:  # a disturbance at one place of every run, not a cause
            top.note, result.withheld = confined_reason(top.effect, stretch)
            return result
        result.top = top
        return result

    def thin_evidence(self, ranked: list[Ranked], result: Ranking) -> None:
        """Say so when the best-transferring cause is run-level
        and too few runs can ever make it significant.

        The cause is the best of the ranked causes, or the ``local`` form of a run-level column that
        no ordering of the runs can make significant (:meth:`untestable_form`) when it transfers
        better than every ranked cause, beyond its window alone and beyond its column's global
        forms. Its smallest reachable p-value (:meth:`smallest_p`) in place of its column's must
        leave its Benjamini–Hochberg q-value at or above
        :data:`svrqp.gap.contract.ALPHA` (module docstring).
        """
        if not ranked or ranked[0].significant:
            return
        best = self.untestable_local(ranked) or (ranked[0] if ranked[0].above_floor else None)
        if best is None or self.parametric(best.effect, len(ranked)):
            # tested between runs by the t-test: its evidence is not bounded by the orderings
            return
        orders = self.surrogates.orderings(best.effect)
        if orders is None:
            return
        column = best.effect.column
        p_min = self.surrogates.smallest_p(best.effect)
        p = [p_min if r.effect.column == column else r.p_raw for r in ranked]
        q_min = float(min(q for q, r in zip(false_discovery_control(p, method="bh"), ranked,
                                            strict=False) if r.effect.column == column))
        if q_min < ALPHA:
            return
        result.untestable = column
        shrink = f"{shrink_of_gain(best.gain):.0%} beyond the refit"
        if best.region is not None:
            what = f"The {column} term {region_text(best.region)}"
            shrink += f", {shrink_of_gain(best.beyond_window):.0%} beyond the window alone"
        else:
            what = f"The level of {column}"
        result.too_thin = (
            f" {what}, one level per run, transfers best ({shrink}), but its {len(orders[0])} run "
            f"levels have only {len(orders)} orderings: no permutation test can give it a p-value "
            f"below {p_min:.2g}, which over {len(ranked)} candidate columns leaves q ≥ {q_min:.2g} "
            f"(above {ALPHA:g}). The transfer evidence is too thin to name it; more runs are "
            "needed.")

    def untestable_local(self, ranked: list[Ranked]) -> Ranked | None:
        """The best :meth:`untestable_form` row above the floor that transfers better than every
        ranked cause and than its own column's row (by
        :data:`svrqp.gap.transfer.windows.LOCAL_MARGIN`), or None."""
        rows = {r.effect.column: r for r in ranked}
        for row in self.unpermutable:
            if row.gain <= ranked[0].gain:
                return None
            if row.above_floor and _better(row, rows[row.effect.column]):
                return row
        return None

    def stronger_unproven(self, ranked: list[Ranked], top: Ranked) -> Ranked | None:
        """An untestable cause that transfers better than ``top`` and explains it away.

        A run-level candidate with fewer than :data:`svrqp.gap.contract.MIN_RUNS` real runs cannot
        reach significance by permuting its run levels, however well it transfers. Naming a weaker
        cause in its place would name its shadow: ``top`` stands only if it adds beyond every such
        cause (conditional test, :meth:`adds`). A cause that was tested and found no better than
        chance is not conditioned on.
        """
        if len(group_slices(self.data.groups[self.data.is_real])) >= MIN_RUNS:
            return None
        for row in ranked:
            if row is top or row.gain <= top.gain:
                break
            if row.effect.run_level and row.above_floor and not self.adds(top, row):
                return row
        return None


def _better(row: Ranked, held: Ranked) -> bool:
    """Whether ``row`` transfers better than ``held`` (fewer parameters win a near tie; the
    ``local`` transform against a global one must be ahead by
    :data:`svrqp.gap.transfer.windows.LOCAL_MARGIN`)."""
    local = (row.effect.transform == "local") != (held.effect.transform == "local")
    if (abs(shrink_of_gain(row.gain) - shrink_of_gain(held.gain))
            < (LOCAL_MARGIN if local else SAME_FIT)):
        return row.effect.parameters < held.effect.parameters
    return row.gain > held.gain
