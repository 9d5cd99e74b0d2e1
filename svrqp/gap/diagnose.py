"""``diagnose``: the sim-to-real gap diagnosis, step by step.

1. **Honest residuals** — fit the baseline on the train rows or read the prediction
   (:mod:`svrqp.gap.model`); the real rows are the others.
2. **Gate** — one-sided: the real rows must fit worse than the train rows (both out of
   sample) and beyond chance (:mod:`svrqp.gap.detect`). No gap, no culprit: candidates that
   would improve the model everywhere may be listed in the reason, none is named.
3. **Localise** — where along the order axis (pooled over the runs, and within single runs)
   and along candidate columns the squared error concentrates (:mod:`svrqp.gap.detect`).
4. **Transfer** — the user's question is "if I add this effect and refit, how much smaller is
   my error on a run I have not fitted?" Every candidate × transform is added to the model
   family and refitted leave-one-unit-out over all rows (units: the ``--group`` groups, or
   contiguous blocks of a record without runs), scored on the real rows
   (:mod:`svrqp.gap.transfer.linear`); the refit without any effect says what more data alone buys.
   Causes are ranked by that transfer gain and tested against surrogates that respect what
   varies where, with the false-discovery rate controlled and confounded pairs checked by
   conditional tests (:mod:`svrqp.gap.transfer.ranking`); this screen refits the linear family. For
   an ``svr`` or ``lssvr`` model the reported numbers of the same-input refit, the best-ranked
   causes and the verdict candidate come from refits of that kernel family itself, its C, ε
   and γ fixed (:mod:`svrqp.gap.transfer.kernel`). The verdict is the best-transferring
   significant cause whose shrink is positive and whose shrink beyond the refit has an
   interval above zero.
5. **Within the real rows** (only with ``within_evidence=True``, ``--within-evidence``) — the
   earlier evidence, discrepancy models fitted on the real rows themselves
   (:mod:`svrqp.gap.within.attribute`), stays under its own keys (``p_within``,
   ``within_shrink``, ``shrink_beyond_base``; null when not asked for): it says what a per-run
   recalibration would remove, which no new run gets, and never enters ``shrink`` or the summary.
   The per-run recalibration base alone (``base``) is always reported.
6. **Report** — :class:`svrqp.gap.words.report.GapReport`: a summary of at most two sentences with
   the transfer shrink (leading with extrapolation when a model input is used outside its train
   range and the refit removes most of the gap), the reasoning in ``verdict.reason``, and every
   model input and candidate against its train range (:mod:`svrqp.gap.model`).

With ``pool=True`` (``svrqp fleet``), after all of that, every candidate the record did not test
is tested on its own surrogate stream (:mod:`svrqp.gap.transfer.pooling`): the p-values are the
report's :attr:`~svrqp.gap.results.document.GapResult.pool_p`, for evidence pooled over records,
and never enter the record's causes, verdict or JSON.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError, SolverError
from svrqp.gap.contract import ALPHA, EVIDENCE_BETWEEN, LINEAR, MIN_AMPLITUDE, MIN_GAIN
from svrqp.gap.data import GapData, blocked_folds, prepare, tau_grid
from svrqp.gap.detect import gap_detected, gate, localise, refit_closes, region_of
from svrqp.gap.model import (
    Baseline,
    base_design,
    base_fit,
    fit_baseline,
    input_use,
    offset_columns,
    offsets_text,
    refit_shrink,
)
from svrqp.gap.question import GapQuestion
from svrqp.gap.results.records import Cause, GateResult, Ranking, Series, Units, Verdict
from svrqp.gap.transfer.candidates import (
    constant_on_real_rows,
    effect_columns,
    region_axis,
    untestable_between_runs,
)
from svrqp.gap.transfer.kernel import FamilyErrors, same_family_errors
from svrqp.gap.transfer.linear import (
    LinearTransfer,
    bootstrap_index,
    shrink_of_gain,
    transfer_shrink,
    transfer_units,
)
from svrqp.gap.transfer.pooling import pool_p_values
from svrqp.gap.transfer.ranking import MAX_SURROGATES as MAX_TRANSFER_SURROGATES, TransferRanker
from svrqp.gap.within.attribute import (
    MAX_SURROGATES,
    AttributionProblem,
    check_surrogates,
    evidence_within,
)
from svrqp.gap.words.report import GapReport
from svrqp.gap.words.verdict import VerdictContext, decide, extrapolation_text, named, summary
from svrqp.metrics import rms

Progress = Callable[[str, float], None]


@dataclass(frozen=True)
class _Findings:
    """What the cause search leaves for the report (:func:`_search_causes`)."""

    context: VerdictContext
    causes: list[Cause]
    verdict: Verdict
    errors_after: dict[str, np.ndarray]
    residual_gate: GateResult | None
    remaining: list[str]
    pool_p: dict[str, float] | None = None


@dataclass(frozen=True)
class _Search:
    """How the cause search runs (:func:`_search_causes`): the ``lag`` time constants, the seed,
    the progress callback, and whether to try the local form, test within the real rows, and
    test every candidate for the pool."""

    taus: np.ndarray
    seed: int
    progress: Progress
    local: bool
    within: bool
    pool: bool


def diagnose(df: pd.DataFrame, question: GapQuestion, *, seed: int = 0,
             surrogates: str = "rotation", n_jobs: int = 1, within_evidence: bool = False,
             progress: Progress | None = None, pool: bool = False) -> GapReport:
    """Diagnose the gap between a model (or a simulation) and real measurements.

    Parameters
    ----------
    df : pandas.DataFrame
        The measurements, one row per sample.
    question : GapQuestion
        What is asked: target, train rows, candidates, and the model's features (with its
        ``model`` kind) or a prediction column, the order and group columns
        (:class:`svrqp.gap.question.GapQuestion`).
    seed : int
        Seed of the surrogates and the bootstrap (results are reproducible).
    surrogates : {"rotation", "continuous"}
        How the within-real-rows significance tests draw surrogates
        (:mod:`svrqp.gap.within.surrogate_tests`): plain rotations within each group (the default),
        or rotations made continuous at the seam — safer when the true cause may be missing from the
        candidates and some of them drift within a run,
        at some loss of power on slow, trend-like effects.
    n_jobs : int
        Threads on which the within-real-rows significance tests run (``-1``: one per core);
        the transfer refits and their tests run on one. The result does not depend on it.
        A record of 13,000 real rows and 32 candidates gains little from a second thread now
        that most of its time is the transfer tests (``benchmarks/results/gap_scale.md``).
    within_evidence : bool
        Also compute the within-real-rows evidence (:mod:`svrqp.gap.within`, step 5 above): the
        causes' ``p_within``, ``within_shrink``, ``within_shrink_ci`` and ``shrink_beyond_base``,
        null otherwise. Off by default: it never enters a shrink, the verdict or the summary,
        and costs about a third of a diagnosis.
    progress : callable, optional
        Called as ``progress(stage, fraction_done)``.
    pool : bool
        Also give every candidate's transfer-test p-value, below the effect floor too
        (:mod:`svrqp.gap.transfer.pooling`), as the report's ``pool_p`` (not in its JSON).

    Returns
    -------
    GapReport
    """
    check_surrogates(surrogates)  # before the work, not after it
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)) or n_jobs == 0:
        raise ProblemError("n_jobs (--jobs): give a number of threads (a positive integer, or -1 "
                           f"for one per core), not {n_jobs!r}")
    started = time.perf_counter()
    report_progress = progress or (lambda stage, done: None)
    report_progress("checking input", 0.0)
    data = prepare(df, question)
    report_progress("fitting the baseline", 0.05)
    baseline = fit_baseline(data, question.model)
    real = data.is_real
    r, groups = baseline.residual[real], data.groups[real]
    B, folds, taus = base_design(data,
                                 baseline), blocked_folds(groups), tau_grid(data.t, data.groups)
    gap = gate(r, groups, baseline.train_reference, data.groups[data.is_train])
    report_progress("localising", 0.15)
    where = localise(r, data.order_name, data.t[real],
                     {c: data.C[real, j] for j, c in enumerate(data.candidates)},
                     folds, groups, data.group_labels)
    exact = _reproduced_exactly(r, data.y)
    units = transfer_units(data.groups, real, baseline.residual)
    context = VerdictContext(
        data, baseline.kind, offsets_text(data), gap, gap_detected(gap),
        base_fit(data, r, B, folds, exact), units,
        [] if exact else input_use(data, r, offset_columns(groups), folds),
        {"rmse_before": float(rms(r)), "rmse_refit": None, "shrink_refit": None,
         "refit_closes_gap": None, "units": units.n_units, "unit_kind": units.kind,
         "thin": units.thin})
    if exact:
        findings = _Findings(context, [], Verdict(column=None, reason="The model reproduces the "
                                         "real rows exactly (the residual is zero to rounding); "
                                         "there is no gap and no cause is named."), {}, None, [])
    else:
        problem = AttributionProblem(r, B, folds, groups, gap.train_rmse,
                                     np.random.default_rng(seed), surrogates,
                                     n_jobs)
        findings = _search_causes(problem, context, baseline,
                                  _Search(taus, seed, report_progress, question.local,
                                          within_evidence, pool))
    report_progress("reporting", 0.98)
    if findings.verdict.region is not None:  # a local verdict: where it acts comes first
        where = [region_of(region_axis(data, findings.verdict.region)[real], r,
                           findings.verdict.region), *where]
    settings = {"alpha": ALPHA, "min_gain": MIN_GAIN, "min_amplitude": MIN_AMPLITUDE,
                "max_surrogates": MAX_SURROGATES, "surrogates": surrogates, "n_folds": len(folds),
                "taus": taus.tolist(), "seed": seed, "transfer_surrogates": MAX_TRANSFER_SURROGATES,
                "local": question.local, "local_along": list(data.along),
                "within_evidence": within_evidence}
    text = summary(findings.context, findings.verdict, exact)
    report = _report(question, baseline, where, findings, text, settings)
    report.runtime_s = time.perf_counter() - started
    report_progress("done", 1.0)
    return report


def _search_causes(problem: AttributionProblem, context: VerdictContext, baseline: Baseline,
                   search: _Search) -> _Findings:
    """Rank and test by transfer (``local``: with the local form too), tabulate the causes and
    decide the verdict; with ``within``, test within the real rows too; with ``pool``, test every
    untested candidate on the pool's own stream, once all of that is decided (``search``).

    The findings carry ``context`` with its ``transfer``
    entry complete (the same-input refit's numbers).
    """
    data, units = context.data, context.units
    real, r, groups = data.is_real, problem.r, problem.groups
    taus, seed, report_progress = search.taus, search.seed, search.progress
    numbers = {}
    if search.within:
        report_progress("computing candidate transforms", 0.2)
        numbers = evidence_within(problem, data, taus, context.base.rmse_after,
                                  lambda stage, done: report_progress(stage, 0.2 + 0.4 * done))
    report_progress("refitting on held-out runs", 0.6)
    ranker = TransferRanker(data, family_of(data, units), taus, np.random.default_rng([seed, 19]),
                            local=search.local)
    ranked = ranker.rank()
    ranker.test(ranked)
    ranking = ranker.choose(ranked)
    report_progress("refitting the model family", 0.8)
    family = same_family_errors(baseline, ranker, ranking)
    rmse_refit = float(rms(family.refit))
    context = replace(context, transfer=context.transfer | {
        "rmse_refit": rmse_refit, "shrink_refit": 1 - rmse_refit / context.transfer["rmse_before"],
        "refit_closes_gap": context.detected and refit_closes(family.refit, groups),
        "family": family.family, "screened_by": LINEAR, "family_note": family.note})
    report_progress("quantifying", 0.9)
    notes = untestable_between_runs(data) | constant_on_real_rows(data) | family.kept_linear
    causes, errors_after = _causes(ranking, r, family, units, units.code[real], numbers, notes,
                                   np.random.default_rng([seed, 20]))
    verdict, residual_gate = _verdict(ranking, causes, errors_after, context, baseline)
    remaining = [c.column for c in causes[1:] if verdict.column and c.significant
                 and (c.note or "").startswith("carries information beyond")]
    pooled = pool_p_values(ranker, seed) if search.pool else None
    return _Findings(context, causes, verdict, errors_after, residual_gate, remaining, pooled)


def _verdict(ranking: Ranking, causes: list[Cause], errors_after: dict[str, np.ndarray],
             context: VerdictContext, baseline: Baseline) -> tuple[Verdict, GateResult | None]:
    """The verdict (:func:`svrqp.gap.words.verdict.decide`) with its reason, and for a named
    cause the gate of the real rows' error once refitted with it (else None).

    A named cause is checked the way a user would act on it: the model family refitted on the
    train rows with its effect (:func:`_train_refit`), which the verdict's reason words.
    """
    data = context.data
    outcome = decide(ranking, causes, context)
    residual_gate = None
    if isinstance(outcome, Cause):
        refit, failure = _train_refit(data, baseline, outcome)
        residual_gate = gate(errors_after[outcome.column], data.groups[data.is_real],
                             baseline.train_reference, data.groups[data.is_train])
        outcome = named(outcome, ranking, context, refit, failure)
    return replace(outcome, reason=outcome.reason + extrapolation_text(context)), residual_gate


def _train_refit(data: GapData, baseline: Baseline,
                 cause: Cause) -> tuple[float | None, str | None]:
    """The shrink of the model family refitted on the
    train rows with the cause's effect (:func:`svrqp.gap.model.refit_shrink`), and why it failed.

    A refit whose solver cannot certify its answer leaves the shrink None and gives the solver's
    first line of error (at most 160 characters); it does not abort the diagnosis.
    """
    effect = effect_columns(data, cause.column, cause.transform, cause.tau, cause.evidence,
                            cause.region)
    try:
        return refit_shrink(data, baseline, effect), None
    except SolverError as err:
        return None, (str(err) or type(err).__name__).splitlines()[0][:160]


def _report(question: GapQuestion, baseline: Baseline, where: list, findings: _Findings,
            text: str, settings: dict) -> GapReport:
    """The :class:`GapReport` of a diagnosis (``runtime_s`` set by the caller)."""
    context = findings.context
    data, units = context.data, context.units
    series = Series(data.target, data.order_name, data.t, data.groups, data.group_labels,
                    data.is_train,
                    data.y, baseline.y_hat, findings.errors_after.get(findings.verdict.column))
    return GapReport(
        target=data.target,
        mode="prediction" if data.prediction is not None else "features",
        model=None if data.prediction is not None else question.model,
        features=data.features,
        prediction=data.prediction_name,
        candidates=data.candidates,
        order=data.order_name,
        group=data.group_name,
        n_rows=len(data.y),
        n_train=int(data.is_train.sum()),
        n_real=int(data.is_real.sum()),
        n_dropped=data.n_dropped,
        n_dropped_short_groups=data.n_dropped_short_groups,
        order_sorted=data.order_sorted,
        gap=context.gap,
        gap_detected=context.detected,
        where=where,
        causes=findings.causes,
        verdict=findings.verdict,
        residual_gate=findings.residual_gate,
        remaining=findings.remaining,
        base=context.base,
        inputs=context.inputs,
        summary=text,
        transfer=context.transfer,
        blocks=units.as_dict() if units.kind == "blocks" else None,
        settings=settings,
        runtime_s=0.0,
        series=series,
        pool_p=findings.pool_p,
    )


def _reproduced_exactly(r: np.ndarray, y: np.ndarray) -> bool:
    """Whether the real-row residual is zero to rounding (relative to the target's magnitude).

    Every later step divides by the residual's sum of squares; a model (or prediction) that
    reproduces the measurements has no gap to explain.
    """
    return bool(rms(r) <= 1e-10 * np.max(np.abs(y)))


def family_of(data: GapData, units: Units) -> LinearTransfer:
    """The linear family the ranking and the tests refit (:mod:`svrqp.gap.transfer.linear`).

    Features mode: least squares of the target on an intercept and the features (the ``mlr``
    model itself; for ``svr`` and ``lssvr`` the screen, whose best causes
    :mod:`svrqp.gap.transfer.kernel` refits with the kernel family). Prediction mode: the
    discrepancy model, target − prediction on an intercept.
    """
    ones = np.ones((len(data.y), 1))
    if data.prediction is not None:
        return LinearTransfer(data.y - data.prediction, ones, units, data.is_real)
    return LinearTransfer(data.y, np.column_stack([ones, data.X]), units, data.is_real)



def _causes(ranking: Ranking, r: np.ndarray, family: FamilyErrors, units: Units,
            real_units: np.ndarray,
            within: dict, notes: dict,
            rng: np.random.Generator) -> tuple[list[Cause], dict[str, np.ndarray]]:
    """The causes table, best transfer first (by the linear
    screen): one row per column with its transfer numbers.

    ``family`` holds the same-family refits (:mod:`svrqp.gap.transfer.kernel`); a cause it did not
    refit keeps the linear screen's numbers, said by its ``family``. ``real_units`` is the held-out
    unit of each real row; ``within`` the numbers of
    :func:`svrqp.gap.within.attribute.evidence_within` (empty unless asked for); ``notes`` the
    attribution's notes on columns.
    """
    index = bootstrap_index(units.n_units, rng)
    causes, errors_after = [], {}
    for row in ranking.ranked:
        effect = row.effect
        name, refit, after = family.of(effect.column)
        after = row.fit.errors if after is None else after
        numbers = transfer_shrink(r, refit, after, real_units, units.n_units, index)
        w_shrink, w_ci, w_q, w_beyond = within.get(effect.column, (None, None, None, None))
        note = row.note or notes.get(effect.column)
        causes.append(Cause(
            column=effect.column, transform=effect.transform, tau=row.tau,
            evidence=EVIDENCE_BETWEEN if effect.block else "within runs",
            p_value=row.q_value, p_raw=row.p_raw, gain=row.gain, significant=row.significant,
            rmse_before=numbers.rmse_before, rmse_after=numbers.rmse_after, shrink=numbers.shrink,
            shrink_ci=numbers.shrink_ci, note=note, ambiguous=row.ambiguous,
            shrink_beyond_base=w_beyond, rmse_refit=numbers.rmse_refit,
            shrink_beyond_refit=numbers.shrink_beyond_refit,
            shrink_beyond_refit_ci=numbers.shrink_beyond_refit_ci,
            tested=row.tested, p_within=w_q, within_shrink=w_shrink, within_shrink_ci=w_ci,
            family=name,
            region=row.region, shrink_beyond_window=None if row.beyond_window is None
            else shrink_of_gain(row.beyond_window),
        ))
        errors_after[effect.column] = after
    return causes, errors_after
