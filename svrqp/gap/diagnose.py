"""``diagnose``: the sim-to-real gap diagnosis, step by step.

1. **Honest residuals** — fit the baseline on the train rows or read the prediction
   (:mod:`svrqp.gap.baseline`); the real rows are the others.
2. **Gate** — one-sided: the real rows must fit worse than the train rows (both out of
   sample) and beyond chance (:mod:`svrqp.gap.gate`). No gap, no culprit: candidates that
   would improve the model everywhere may be listed in the reason, none is named.
3. **Localise** — where along the order axis (pooled over the runs, and within single runs)
   and along candidate columns the squared error concentrates (:mod:`svrqp.gap.localise`).
4. **Transfer** — the user's question is "if I add this effect and refit, how much smaller is
   my error on a run I have not fitted?" Every candidate × transform is added to the model
   family and refitted leave-one-unit-out over all rows (units: the ``--group`` groups, or
   contiguous blocks of a record without runs), scored on the real rows
   (:mod:`svrqp.gap.transfer`); the refit without any effect says what more data alone buys.
   Causes are ranked by that transfer gain and tested against surrogates that respect what
   varies where, with the false-discovery rate controlled and confounded pairs checked by
   conditional tests (:mod:`svrqp.gap.ranking`). The verdict is the best-transferring
   significant cause whose shrink beyond the refit has an interval above zero.
5. **Within the real rows** — the earlier evidence, discrepancy models fitted on the real rows
   themselves (:mod:`svrqp.gap.attribute`), stays under its own keys (``p_within``,
   ``within_shrink``, ``shrink_beyond_base``, ``base``): it says what a per-run recalibration
   would remove, which no new run gets, and never enters ``shrink`` or the summary.
6. **Report** — :class:`svrqp.gap.report.GapReport`: a summary of at most two sentences with
   the transfer shrink (leading with extrapolation when a model input is used outside its train
   range and the refit removes most of the gap), the reasoning in ``verdict.reason``, and every
   model input and candidate against its train range (:mod:`svrqp.gap.inputs`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError
from svrqp.gap import attribute as attr
from svrqp.gap.attribute import (
    Attribution,
    AttributionProblem,
    attribute,
    build_banks,
    constant_on_real_rows,
    effect_columns,
    untestable_between_runs,
)
from svrqp.gap.baseline import Baseline, fit_baseline
from svrqp.gap.between import EVIDENCE_BETWEEN
from svrqp.gap.blocks import blocked_folds, holds_out_groups
from svrqp.gap.discrepancy import CrossValidatedDiscrepancy
from svrqp.gap.figures import Series, unit_of
from svrqp.gap.gate import GateResult, gap_detected, gate, noise_pvalue
from svrqp.gap.inputs import InputUse, input_use
from svrqp.gap.localise import localise
from svrqp.gap.prepare import GapData, prepare
from svrqp.gap.quantify import estimate_shrink, refit_shrink
from svrqp.gap.ranking import MAX_SURROGATES as MAX_TRANSFER_SURROGATES
from svrqp.gap.ranking import Ranking, TransferRanker
from svrqp.gap.report import BaseFit, Cause, GapReport, Verdict
from svrqp.gap.transfer import MIN_BLOCKS, LinearTransfer, Units, bootstrap_index, transfer_shrink, transfer_units
from svrqp.gap.transforms import smooth, standardised, tau_grid

Progress = Callable[[str, float], None]


def recalibration_inputs(data: GapData, baseline: Baseline) -> np.ndarray:
    """The model's own inputs in the discrepancy base, on the real rows (may have no column).

    Features mode: the features, and for a non-linear model also its prediction (a linear
    model's prediction is already in the span of its features), each also smoothed
    (:func:`svrqp.gap.transforms.smooth`). The smoothed copies matter: sensor noise in the
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
    cross-validation to hold out whole groups (:func:`svrqp.gap.blocks.holds_out_groups`) — an
    offset between groups is then part of the gap a candidate may explain, and differences
    between groups are often the best evidence (an error that scales with each run's feed);
    otherwise one intercept per group, fitted on the other blocks of the same group: with two or
    three groups an offset between them cannot be told apart from any candidate's group means,
    and circular-shift surrogates (which keep each group's level) could never show otherwise.
    """
    return np.column_stack([offset_columns(data.groups[data.is_real]), recalibration_inputs(data, baseline)])


def diagnose(
    df: pd.DataFrame,
    *,
    target: str,
    train: str | np.ndarray | pd.Series,
    features: str | list[str] | None = None,
    prediction: str | None = None,
    candidates: str | list[str],
    order: str | None = None,
    group: str | None = None,
    model: str = "mlr",
    seed: int = 0,
    surrogates: str = "rotation",
    n_jobs: int = 1,
    progress: Progress | None = None,
) -> GapReport:
    """Diagnose the gap between a model (or a simulation) and real measurements.

    Parameters
    ----------
    df : pandas.DataFrame
        The measurements, one row per sample.
    target : str
        Measured column (e.g. ``"error_um"``).
    train : str or boolean mask
        Pandas query selecting the rows the model was built on (e.g. ``"batch == 'x1'"``);
        the other rows are the *real* rows where the gap is assessed.
    features : str or list of str, optional
        Model inputs; a baseline of kind ``model`` is fitted on the train rows. Exclusive
        with ``prediction``.
    prediction : str, optional
        Column holding a simulation's prediction (nothing is fitted).
    candidates : str or list of str
        Measured columns that may carry the unmodelled effect (a model feature may be a
        candidate: then only its ``rate`` and ``lag`` are tested).
    order : str, optional
        Time (min) or position (mm) column; rates and filters run along it.
    group : str, optional
        Run/batch column; transforms restart and cross-validation is blocked per group.
    model : {"mlr", "svr", "lssvr"}
        Baseline model family (features mode).
    seed : int
        Seed of the surrogates and the bootstrap (results are reproducible).
    surrogates : {"rotation", "continuous"}
        How the significance tests draw surrogates (:mod:`svrqp.gap.attribute`): plain
        rotations within each group (the default), or rotations made continuous at the seam —
        safer when the true cause may be missing from the candidates and some of them drift
        within a run, at some loss of power on slow, trend-like effects.
    n_jobs : int
        Threads on which the within-real-rows significance tests run (``-1``: one per core);
        the transfer refits and their tests run on one. The result does not depend on it.
        A record of 13,000 real rows and 32 candidates gains little from a second thread now
        that most of its time is the transfer tests (``benchmarks/results/gap_scale.md``).
    progress : callable, optional
        Called as ``progress(stage, fraction_done)``.

    Returns
    -------
    GapReport
    """
    attr.check_surrogates(surrogates)  # before the work, not after it
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)) or n_jobs == 0:
        raise ProblemError(f"n_jobs (--jobs): give a number of threads (a positive integer, or -1 for one per core), "
                           f"not {n_jobs!r}")
    started = time.perf_counter()
    report_progress = progress or (lambda stage, done: None)
    rng = np.random.default_rng(seed)

    report_progress("checking input", 0.0)
    data = prepare(df, target=target, train=train, features=features, prediction=prediction,
                   candidates=candidates, order=order, group=group)
    report_progress("fitting the baseline", 0.05)
    baseline = fit_baseline(data, model)
    real = data.is_real
    r, groups = baseline.residual[real], data.groups[real]
    B = base_design(data, baseline)
    folds = blocked_folds(groups)
    taus = tau_grid(data.t, data.groups)

    gap = gate(r, groups, baseline.train_reference, data.groups[data.is_train])
    report_progress("localising", 0.15)
    where = localise(r, data.order_name, data.t[real], {c: data.C[real, j] for j, c in enumerate(data.candidates)}, folds,
                     groups, data.group_labels)
    detected = gap_detected(gap)
    exact = _reproduced_exactly(r, data.y)
    base, base_errors = _base_fit(data, r, B, folds, exact)
    inputs = [] if exact else input_use(data, r, offset_columns(groups), folds)
    units = transfer_units(data.groups, real, baseline.residual)
    transfer = {"rmse_before": float(np.sqrt(np.mean(r**2))), "rmse_refit": None, "shrink_refit": None,
                "refit_closes_gap": None, "units": units.n_units, "unit_kind": units.kind, "thin": units.thin}
    if exact:
        causes, errors_after, residual_gate, remaining = [], {}, None, []
        verdict = Verdict(column=None, reason="The model reproduces the real rows exactly (the residual is zero to "
                                              "rounding); there is no gap and no cause is named.")
    else:
        report_progress("computing candidate transforms", 0.2)
        problem = AttributionProblem(r, B, folds, groups, gap.train_rmse, rng, surrogates, n_jobs)
        attribution = attribute(problem, build_banks(data, taus),
                                lambda stage, done: report_progress(stage, 0.2 + 0.4 * done))
        report_progress("refitting on held-out runs", 0.6)
        within = _within_numbers(attribution, r, groups, base, rng)
        ranker = TransferRanker(data, family_of(data, baseline, units), taus, np.random.default_rng([seed, 19]))
        ranked = ranker.rank()
        ranker.test(ranked)
        ranking = ranker.choose(ranked)
        refit_errors = ranker.refit.errors
        transfer["rmse_refit"] = float(np.sqrt(np.mean(refit_errors**2)))
        transfer["shrink_refit"] = 1 - transfer["rmse_refit"] / transfer["rmse_before"]
        transfer["refit_closes_gap"] = detected and refit_closes(refit_errors, groups)
        report_progress("quantifying", 0.9)
        notes = untestable_between_runs(data) | constant_on_real_rows(data)  # the rival notes are the ranking's
        causes, errors_after = _causes(ranking, r, refit_errors, units, units.code[real], within, notes,
                                       np.random.default_rng([seed, 20]))
        verdict, residual_gate = _verdict(ranking, causes, errors_after, data, baseline, groups, gap, detected,
                                          base, units, transfer["rmse_refit"], transfer["refit_closes_gap"])
        verdict = dataclasses.replace(verdict, reason=verdict.reason + _extrapolation_text(data, inputs, transfer,
                                                                                           units))
        remaining = [c.column for c in causes[1:] if verdict.column and c.significant
                     and (c.note or "").startswith("carries information beyond")]
    report_progress("reporting", 0.98)

    series = Series(data.target, data.order_name, data.t, data.groups, data.group_labels, data.is_train,
                    data.y, baseline.y_hat, errors_after.get(verdict.column))
    report = GapReport(
        target=data.target,
        mode="prediction" if data.prediction is not None else "features",
        model=None if data.prediction is not None else model,
        features=data.features,
        prediction=data.prediction_name,
        candidates=data.candidates,
        order=data.order_name,
        group=data.group_name,
        n_rows=len(data.y),
        n_train=int(data.is_train.sum()),
        n_real=int(real.sum()),
        n_dropped=data.n_dropped,
        n_dropped_short_groups=data.n_dropped_short_groups,
        gap=gap,
        gap_detected=detected,
        where=where,
        causes=causes,
        verdict=verdict,
        residual_gate=residual_gate,
        remaining=remaining,
        base=base,
        inputs=inputs,
        summary=_summary(data, gap, detected, verdict, exact, inputs, transfer, units),
        transfer=transfer,
        blocks=units.as_dict() if units.kind == "blocks" else None,
        settings={
            "alpha": attr.ALPHA, "min_gain": attr.MIN_GAIN, "min_amplitude": attr.MIN_AMPLITUDE,
            "max_surrogates": attr.MAX_SURROGATES, "surrogates": surrogates, "n_folds": len(folds),
            "taus": taus.tolist(), "seed": seed, "transfer_surrogates": MAX_TRANSFER_SURROGATES,
        },
        runtime_s=0.0,
        series=series,
    )
    report.runtime_s = time.perf_counter() - started
    report_progress("done", 1.0)
    return report


def _reproduced_exactly(r: np.ndarray, y: np.ndarray) -> bool:
    """Whether the real-row residual is zero to rounding (relative to the target's magnitude).

    Every later step divides by the residual's sum of squares; a model (or prediction) that
    reproduces the measurements has no gap to explain.
    """
    return bool(np.sqrt(np.mean(r**2)) <= 1e-10 * np.max(np.abs(y)))


def family_of(data: GapData, baseline: Baseline, units: Units) -> LinearTransfer:
    """The model family the transfer refits use (:mod:`svrqp.gap.transfer`).

    Features mode: least squares of the target on an intercept and the features (``mlr``;
    for ``svr`` and ``lssvr`` the same linear family, see the module docstring). Prediction
    mode: the discrepancy model, target − prediction on an intercept.
    """
    ones = np.ones((len(data.y), 1))
    if data.prediction is not None:
        return LinearTransfer(data.y - data.prediction, ones, units, data.is_real)
    return LinearTransfer(data.y, np.column_stack([ones, data.X]), units, data.is_real)


def _within_numbers(attribution: Attribution, r: np.ndarray, groups: np.ndarray, base: BaseFit,
                    rng: np.random.Generator) -> dict[str, tuple[float, tuple[float, float], float, float | None]]:
    """Per column: the within-real-rows shrink, its interval, its p-value (BH) and its shrink beyond the base.

    These numbers come from discrepancy models fitted on the real rows themselves: they say
    what a per-run recalibration with the effect would remove, not what the effect buys on a
    new run, and stay under their own keys.
    """
    out = {}
    for column in dict.fromkeys(e.test.column for e in attribution.evidence):
        ev = attribution.best(column)
        estimate = estimate_shrink(r, attribution.losses.errors(ev.test), groups, rng)
        beyond = 1.0 - estimate.rmse_after / base.rmse_after if base.rmse_after > 0 else None
        out[column] = (estimate.shrink, (estimate.ci_low, estimate.ci_high), ev.q_value, beyond)
    return out


def _causes(ranking: Ranking, r: np.ndarray, refit_errors: np.ndarray, units: Units, real_units: np.ndarray,
            within: dict, notes: dict, rng: np.random.Generator) -> tuple[list[Cause], dict[str, np.ndarray]]:
    """The causes table, best transfer first: one row per column with its transfer numbers.

    ``real_units`` is the held-out unit of each real row; ``within`` the numbers of
    :func:`_within_numbers`; ``notes`` the attribution's notes on columns.
    """
    index = bootstrap_index(units.n_units, rng)
    causes, errors_after = [], {}
    for row in ranking.ranked:
        effect = row.effect
        numbers = transfer_shrink(r, refit_errors, row.fit.errors, real_units, units.n_units, index)
        w_shrink, w_ci, w_q, w_beyond = within.get(effect.column, (None, None, None, None))
        note = row.note or notes.get(effect.column)
        causes.append(Cause(
            column=effect.column, transform=effect.transform, tau=row.tau,
            evidence=EVIDENCE_BETWEEN if effect.run_level else "within runs",
            p_value=row.q_value, p_raw=row.p_raw, gain=row.gain, significant=row.significant,
            rmse_before=numbers.rmse_before, rmse_after=numbers.rmse_after, shrink=numbers.shrink,
            shrink_ci=numbers.shrink_ci, round=1, note=note, ambiguous=row.ambiguous,
            shrink_beyond_base=w_beyond, rmse_refit=numbers.rmse_refit,
            shrink_beyond_refit=numbers.shrink_beyond_refit, shrink_beyond_refit_ci=numbers.shrink_beyond_refit_ci,
            tested=row.tested, p_within=w_q, within_shrink=w_shrink, within_shrink_ci=w_ci,
        ))
        errors_after[effect.column] = row.fit.errors
    return causes, errors_after


def _offsets_text(data: GapData) -> str:
    """The offsets of the discrepancy base in words (:func:`offset_columns`)."""
    if one_offset(data.groups[data.is_real]):
        return "one offset"
    return f"one offset per {data.group_name}"


def _base_fit(data: GapData, r: np.ndarray, B: np.ndarray, folds: list[np.ndarray],
              exact: bool) -> tuple[BaseFit, np.ndarray]:
    """The base discrepancy model alone, out of sample (what every cause's shrink includes), and its errors."""
    offsets = _offsets_text(data)
    description = offsets if data.prediction is not None else f"{offsets} and a recalibration of the model's inputs"
    rmse_before = float(np.sqrt(np.mean(r**2)))
    if exact:
        return BaseFit(description, 0.0, 0.0), np.zeros_like(r)
    errors = CrossValidatedDiscrepancy(r, B, folds).errors_base
    rmse_after = float(np.sqrt(np.mean(errors**2)))
    return BaseFit(description, rmse_after, 1.0 - rmse_after / rmse_before), errors


def _refit_text(refit: float | None, column: str) -> str:
    """The verdict's refit of the model family on the train rows, in words (a loss said as one)."""
    if refit is None:
        return f"the model cannot be refitted with it as an input, since {column} is not recorded on every train row."
    if refit < 0:
        return (f"refitting the model on the train rows with it as an input makes the real-row error larger "
                f"({refit:.0%}): what the train rows show of it does not carry over to the real rows.")
    return f"refitting the model with it as an input shrinks it by {refit:.0%}."


def _names(columns: list[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return columns[0] if len(columns) == 1 else f"{', '.join(columns[:-1])} and {columns[-1]}"


def _effect_text(effect: Cause | Verdict, order_name: str) -> str:
    """``lag of T4_C (τ = 78.3 min)``, or a run-level candidate's level with how it was tested."""
    text = f"{effect.transform} of {effect.column}"
    if effect.tau is not None:
        text += f" (τ = {_quantity(effect.tau, unit_of(order_name))})"
    if effect.evidence == EVIDENCE_BETWEEN:
        text += (f" (constant within each run, scaling a profile along {order_name}; tested between runs)")
    return text


def _quantity(value: float, unit: str | None) -> str:
    """``4.09 µm``, or the bare number for a column whose name carries no unit."""
    return f"{value:.3g} {unit}" if unit else f"{value:.3g}"




def refit_closes(refit_real: np.ndarray, groups: np.ndarray) -> bool:
    """Whether the refit alone, same inputs, leaves nothing but noise on the real rows.

    DESIGN §4: a candidate is the gap's cause only if it explains what more data does not. When
    the leave-one-unit-out refit leaves a real-row error no larger than the noise level beyond
    chance (the gate's excess-over-noise test, :func:`svrqp.gap.gate.noise_pvalue`), the gap was
    the model used outside its data; a candidate that still trims the remaining noise improves the
    model everywhere, it is not the gap's cause. (The train rows are no reference here: a withheld
    effect that acts on them as well inflates their error as much as the refit's.)
    """
    return noise_pvalue(refit_real, groups) >= attr.ALPHA


def _verdict(ranking: Ranking, causes: list[Cause], errors_after: dict[str, np.ndarray], data: GapData,
             baseline: Baseline, groups: np.ndarray, gap: GateResult, detected: bool, base: BaseFit,
             units: Units, refit_rmse: float, refit_closes_gap: bool) -> tuple[Verdict, GateResult | None]:
    """The cause the engine stands behind: the best-transferring significant one (:mod:`svrqp.gap.ranking`).

    It must come with a gap (one-sided gate), pass the transfer test, leave the real rows better
    than the given model does (``shrink > 0``), and — with enough held-out units for a
    bootstrap over them to mean anything (:data:`svrqp.gap.transfer.THIN_UNITS`) — its shrink
    beyond the refit must have an interval above zero. With thin evidence the reason and the
    summary say so instead.
    """
    thin = _thin_text(units)
    recalibration = (f" A per-run recalibration fitted on the real rows themselves ({base.description}) would "
                     f"remove {base.shrink:.0%} of the real-row error; no new run gets that.")
    everywhere = [c.column for c in causes if c.significant and c.shrink_beyond_refit > 0]
    if not detected:
        reason = (f"No gap: the real-row RMSE {gap.real_rmse:.3g} is {'not above' if gap.real_rmse <= gap.train_rmse else 'not significantly above'} "
                  f"the train rows' {_train_label(data)} error ({gap.train_rmse:.3g}) beyond chance; no column is "
                  "named as the gap's cause.")
        if everywhere:
            reason += (f" Adding {_names(everywhere)} would still improve the model on held-out runs everywhere "
                       "(see the causes table).")
        return Verdict(column=None, reason=reason, thin=units.thin), None
    if refit_closes_gap:
        reason = (f"Refitting the model leave-one-{_unit_word(units)}-out over all rows, with the same inputs, leaves "
                  f"a real-row RMSE of {refit_rmse:.3g}, no larger than the measurement noise beyond chance: the "
                  "gap is the model's use outside its data, and no column is named as its cause.")
        if everywhere:
            reason += (f" Adding {_names(everywhere)} would still improve the refitted model on held-out "
                       f"{_unit_word(units)}s everywhere (see the causes table).")
        return Verdict(column=None, reason=reason + thin, thin=units.thin), None
    top = ranking.top
    if top is None:
        reason = ("No candidate improves the model on held-out runs beyond chance (transfer surrogate test, "
                  f"false-discovery rate {attr.ALPHA:g}, effect floor {attr.MIN_GAIN:.0%} of the refit's squared "
                  f"error).{thin}{recalibration}")
        if ranking.withheld:
            reason = ranking.withheld + thin + recalibration
        return Verdict(column=None, reason=reason, thin=units.thin), None
    cause = next(c for c in causes if c.column == top.effect.column)
    if cause.shrink <= 0.0:
        reason = (f"The {_effect_text(cause, data.order_name)} passes the transfer test (q = {cause.p_value:.2g}) and "
                  f"adds {cause.shrink_beyond_refit:.0%} to a refit, but the refit with it still leaves the real-row "
                  f"error larger than the given model's ({cause.rmse_after:.3g} against {cause.rmse_before:.3g}); no "
                  f"cause is named.{thin}{recalibration}")
        return Verdict(column=None, reason=reason, thin=units.thin), None
    if cause.shrink_beyond_refit_ci[0] <= 0.0 and not units.thin:
        reason = (f"The {_effect_text(cause, data.order_name)} passes the transfer test (q = {cause.p_value:.2g}), "
                  f"but what it adds to a refit is not above zero on every resample of the held-out "
                  f"{_unit_word(units)}s: {cause.shrink_beyond_refit:.0%} (95 % CI "
                  f"{cause.shrink_beyond_refit_ci[0]:.0%} … {cause.shrink_beyond_refit_ci[1]:.0%}); no cause is named."
                  f"{thin}{recalibration}")
        return Verdict(column=None, reason=reason, thin=units.thin), None
    train_refit = refit_shrink(data, baseline, effect_columns(data, cause.column, cause.transform, cause.tau,
                                                              cause.evidence))
    after = errors_after[cause.column]
    residual_gate = gate(after, groups, baseline.train_reference, data.groups[data.is_train])
    reason = (f"The {_effect_text(cause, data.order_name)} transfers: refitting the model with it, "
              f"leave-one-{_unit_word(units)}-out over all rows, shrinks the real-row RMSE from "
              f"{cause.rmse_before:.3g} to {cause.rmse_after:.3g} ({cause.shrink:.0%}, 95 % CI {cause.shrink_ci[0]:.0%} … "
              f"{cause.shrink_ci[1]:.0%}), {cause.shrink_beyond_refit:.0%} beyond the same refit without it "
              f"({cause.rmse_refit:.3g}; CI {cause.shrink_beyond_refit_ci[0]:.0%} … "
              f"{cause.shrink_beyond_refit_ci[1]:.0%}); transfer test q = {cause.p_value:.2g}. "
              + _capitalised(_refit_text(train_refit, cause.column)) + thin + recalibration)
    if ranking.ambiguous_with:
        reason += (f" On held-out runs it cannot be told apart from {_names(ranking.ambiguous_with)} (neither adds "
                   "to the other in a conditional transfer test); it stays named because it transfers best.")
    return Verdict(column=cause.column, reason=reason, transform=cause.transform, tau=cause.tau,
                   evidence=cause.evidence, shrink=cause.shrink, shrink_ci=cause.shrink_ci,
                   refit_shrink=train_refit, rmse_before=cause.rmse_before, rmse_after=cause.rmse_after,
                   p_value=cause.p_value, ambiguous_with=list(ranking.ambiguous_with), rmse_refit=cause.rmse_refit,
                   shrink_beyond_refit=cause.shrink_beyond_refit,
                   shrink_beyond_refit_ci=cause.shrink_beyond_refit_ci, thin=units.thin), residual_gate


def _capitalised(text: str) -> str:
    return text[:1].upper() + text[1:]


def _unit_word(units: Units) -> str:
    return "block" if units.kind == "blocks" else "run"


def _thin_text(units: Units) -> str:
    """The sentence on thin or short transfer evidence (empty when there is none to make)."""
    if units.kind == "blocks" and units.short:
        return (f" The record is too short for {MIN_BLOCKS} blocks as long as the residual stays correlated "
                f"({units.decorrelation_rows} rows): it is cut into {units.n_units} shorter blocks, so the transfer "
                "numbers are optimistic.")
    if units.thin:
        return (f" Only {units.n_units} held-out {_unit_word(units)}s carry the transfer evidence: it is thin, and "
                "one more run could change it.")
    return ""


def _train_label(data: GapData) -> str:
    """How the train-row error was measured: the footing the real rows are compared on."""
    return "prediction" if data.prediction is not None else "cross-validated"


def _summary(data: GapData, gap: GateResult, detected: bool, verdict: Verdict, exact: bool,
             inputs: list[InputUse], transfer: dict, units: Units) -> str:
    """At most two sentences and 60 words: the gap, and what fixes it on held-out runs."""
    unit = unit_of(data.target)
    n_real = int(data.is_real.sum())
    if exact:
        return f"On the {n_real} real rows the model reproduces {data.target} exactly: no gap, no cause named."
    first = (f"On {n_real} real rows {data.target} is off by {_quantity(gap.real_rmse, unit)} RMS against "
             f"{_quantity(gap.train_rmse, unit)} {_train_label(data)} on the train rows")
    if not detected:
        return first + "; that is no gap, so no cause is named."
    held = f"{units.n_units} held-out {_unit_word(units)}s"
    caveat = ("; thin evidence" if units.thin else "") + ("; blocks shorter than the error's correlation"
                                                        if units.kind == "blocks" and units.short else "")
    extrapolated = [u for u in inputs if u.role == "input" and u.extrapolated]
    refit_gain = transfer["rmse_before"] - (transfer["rmse_refit"] or transfer["rmse_before"])
    if extrapolated and refit_gain >= 0.5 * (gap.real_rmse - gap.train_rmse):
        worst = _most_outside(extrapolated)
        second = (f"The model is used outside its data ({worst.column} on {worst.outside:.0%} of real rows); "
                  f"refitting with the new runs removes {transfer['shrink_refit']:.0%}")
        if verdict.column is not None:
            second += f", adding the {_short_effect(verdict)} {verdict.shrink:.0%}"
        return f"{first}. {second} on {held}" + (f" ({caveat[2:]})." if caveat else ".")
    if verdict.column is not None:
        second = (f"Adding the {_short_effect(verdict)} and refitting shrinks it by {verdict.shrink:.0%} on "
                  f"{held} (refit alone: {transfer['shrink_refit']:.0%}{caveat})")
        if verdict.ambiguous_with:
            second += (f"; {_names(verdict.ambiguous_with[:2])} "
                       + ("does" if len(verdict.ambiguous_with) == 1 else "do") + " about as well")
        return f"{first}. {second}."
    if transfer.get("refit_closes_gap"):
        return (f"{first}. Refitting with the new {_unit_word(units)}s removes {transfer['shrink_refit']:.0%} and "
                f"leaves only noise on {held}, so no cause is named" + (f" ({caveat[2:]})." if caveat else "."))
    return f"{first}. No candidate improves a refit on {held} beyond chance" + (f" ({caveat[2:]})." if caveat else ".")


def _most_outside(uses: list[InputUse]) -> InputUse:
    """The input used furthest outside its data: most real rows outside, then the largest recalibration."""
    return max(uses, key=lambda u: (u.outside, u.recalibration_shrink))


def _short_effect(verdict: Verdict) -> str:
    """``lag of T1_C (τ 125)`` — the verdict's effect in few words."""
    text = f"{verdict.transform} of {verdict.column}"
    if verdict.evidence == EVIDENCE_BETWEEN:
        return text + " (constant within each run)"
    return text + (f" (τ {verdict.tau:.3g})" if verdict.tau is not None else "")


def _extrapolation_text(data: GapData, inputs: list[InputUse], transfer: dict, units: Units) -> str:
    """The reason's sentence on model inputs used outside their train range (empty when none is)."""
    extrapolated = [u for u in inputs if u.role == "input" and u.extrapolated]
    if not extrapolated:
        return ""
    worst = _most_outside(extrapolated)
    text = (f" The model is used beyond its data: {worst.column} lies outside its train range "
            f"({_quantity(worst.train_low, None)} … {_quantity(worst.train_high, unit_of(worst.column))}) on "
            f"{worst.outside:.0%} of the real rows; refitting leave-one-{_unit_word(units)}-out over all rows "
            + (f"removes {transfer['shrink_refit']:.0%} of the real-row error" if transfer["shrink_refit"] > 0
               else f"does not reduce the real-row error (the held-out {_unit_word(units)}s lie outside the others' "
                    "range too)"))
    offsets = _offsets_text(data)
    if worst.beyond_offsets is not None and worst.beyond_offsets <= 0:
        return text + f", and recalibrating it removes nothing out of sample beyond what {offsets} alone does."
    if worst.recalibration_shrink <= 0:
        return text + ", and recalibrating it on the real rows does not reduce the error out of sample."
    text += f", while recalibrating it on the real rows would remove {worst.recalibration_shrink:.0%}"
    if worst.beyond_offsets is not None:
        text += f", {worst.beyond_offsets:.0%} of what {offsets} alone leaves"
    return text + "."
