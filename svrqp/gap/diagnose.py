"""``diagnose``: the sim-to-real gap diagnosis, step by step.

1. **Honest residuals** — fit the baseline on the train rows or read the prediction
   (:mod:`svrqp.gap.baseline`); the real rows are the others.
2. **Gate** — is the real-row error beyond the train rows' out-of-sample error, is it white
   (:mod:`svrqp.gap.gate`)?
3. **Localise** — where along the order axis (pooled over the runs, and within single runs)
   and along candidate columns the squared error concentrates (:mod:`svrqp.gap.localise`).
4. **Attribute** — which candidate × transform explains it beyond chance, controlling the
   false-discovery rate and confounding (:mod:`svrqp.gap.attribute`); a candidate that
   holds one value through each run is also tested between runs (:mod:`svrqp.gap.between`).
5. **Quantify** — out-of-sample shrink with a block-bootstrap interval, the gate re-run on what
   is left, and a refit of the model family with the effect as an input
   (:mod:`svrqp.gap.quantify`); every significant cause is compared with the top one by a
   paired block-bootstrap test of their out-of-sample losses (:mod:`svrqp.gap.compare`,
   :func:`mark_ties`). A verdict names a cause only when its shrink interval also excludes
   zero — significance says the candidate carries information, the interval that the real-row
   error actually shrinks — and when the interval of its shrink *beyond the base alone*
   (:func:`_base_fit`) excludes zero as well: the effect must beat the base it is added to.

Causes that cannot be told apart
    Two kinds of evidence answer "is it this column or that one?". The conditional tests of
    :mod:`svrqp.gap.attribute` ask whether each carries information beyond the other, on the
    rows where they decorrelate; the paired loss test asks whether either fits the real rows
    better. When the conditional tests separate neither column, the paired test decides if it
    can, then parsimony between two columns that each pass on their own (the one needing
    fewer parameters, when it fits no worse; :mod:`svrqp.gap.attribute`); failing both, the
    verdict is withheld (``column: null``) and ``ambiguous_with`` lists both. When the
    conditional tests favour the top cause (or credit each with its own information), or
    parsimony does, but the paired test finds their fits equal, the verdict **stays** on the
    top cause — the decorrelated evidence is the sharper of the two, and it is not a guess —
    while ``ambiguous_with``, the ``ambiguous`` flag and ``p_paired`` of each tied cause, the
    verdict's reason and the one-sentence summary all say that the others explain the gap
    about as well.
6. **Report** — :class:`svrqp.gap.report.GapReport`; in features mode it also says whether
   the model is used beyond its data: each input's range on the train and the real rows and
   what recalibrating it alone does, beyond the offsets too (:mod:`svrqp.gap.inputs`).

The discrepancy models of steps 4–5 use the base regressors "offsets + the model's features
(raw and smoothed, + its prediction for a non-linear model)" in features mode, so an effect
gets credit only for what a linear recalibration of the model itself cannot do, and the
offsets alone in prediction mode (:func:`recalibration_inputs`, :func:`base_design`). Each
cause's shrink is for that effect alone added to this base, against the model's raw residual;
the report's ``base`` says what the base alone already does (out of sample), so that a reader
can tell the effect's own part from that of the offsets and the recalibration.
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
    Evidence,
    attribute,
    build_banks,
    constant_on_real_rows,
    effect_columns,
    untestable_between_runs,
)
from svrqp.gap.baseline import Baseline, fit_baseline
from svrqp.gap.between import EVIDENCE_BETWEEN
from svrqp.gap.blocks import blocked_folds, holds_out_groups
from svrqp.gap.compare import PairedComparison
from svrqp.gap.discrepancy import CrossValidatedDiscrepancy
from svrqp.gap.figures import Series, unit_of
from svrqp.gap.gate import GateResult, gap_detected, gate
from svrqp.gap.inputs import InputUse, input_use
from svrqp.gap.localise import Region, localise
from svrqp.gap.prepare import GapData, prepare
from svrqp.gap.quantify import estimate_shrink, refit_shrink, shrink_interval
from svrqp.gap.report import BaseFit, Cause, GapReport, Verdict
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
        Threads on which the significance tests run (``-1``: one per core). The result does
        not depend on it. On two cores a record of 13,000 real rows and 32 candidates takes
        about 0.7 of the time of one thread; a short one gains nothing
        (``benchmarks/results/gap_scale.md``).
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
    if exact:
        causes, errors_after, residual_gate, remaining = [], {}, None, []
        verdict = Verdict(column=None, reason="The model reproduces the real rows exactly (the residual is zero to "
                                              "rounding); there is no gap and no cause is named.")
    else:
        report_progress("computing candidate transforms", 0.2)
        problem = AttributionProblem(r, B, folds, groups, gap.train_rmse, rng, surrogates, n_jobs)
        attribution = attribute(problem, build_banks(data, taus),
                                lambda stage, done: report_progress(stage, 0.2 + 0.65 * done))
        attribution.notes = untestable_between_runs(data) | constant_on_real_rows(data) | attribution.notes
        report_progress("quantifying", 0.85)
        representatives = _representatives(attribution)
        causes, errors_after = _causes(attribution, representatives, r, groups, rng, base_errors)
        tests = {ev.test.column: ev.test for ev in representatives}
        causes = mark_ties(causes, attribution.ambiguous,
                           lambda top, other: attribution.losses.compare(tests[top], tests[other]))
        verdict, residual_gate = _verdict(attribution, causes, errors_after, data, baseline, groups, gap, detected,
                                          base, base_errors, rng)
        remaining = [e.test.column for e in attribution.accepted[1:]] if verdict.column else []
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
        summary=_summary(data, gap, detected, where, verdict, exact, inputs),
        settings={
            "alpha": attr.ALPHA, "min_gain": attr.MIN_GAIN, "min_amplitude": attr.MIN_AMPLITUDE,
            "max_surrogates": attr.MAX_SURROGATES, "surrogates": surrogates, "n_folds": len(folds),
            "taus": taus.tolist(), "seed": seed,
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


def _representatives(attribution: Attribution) -> list[Evidence]:
    """One test per column, ranked: accepted effects, undecidable rivals, then by evidence."""
    first = list(attribution.accepted[:1])
    first += [_best(attribution, c) for c in attribution.ambiguous]
    first += attribution.accepted[1:]
    taken = {e.test.column for e in first}
    rest = [_best(attribution, c) for c in dict.fromkeys(e.test.column for e in attribution.evidence)
            if c not in taken]
    rest.sort(key=lambda e: (not e.passes, -e.test.gain))
    return first + rest


def _best(attribution: Attribution, column: str) -> Evidence:
    """A column's test: the one that stood for it in the rival checks, else its strongest (passing first)."""
    if column in attribution.chosen:
        return attribution.chosen[column]
    own = [e for e in attribution.evidence if e.test.column == column]
    return max(own, key=lambda e: (e.passes, e.test.gain))


def _causes(attribution: Attribution, representatives: list[Evidence], r: np.ndarray, groups: np.ndarray,
            rng: np.random.Generator, base_errors: np.ndarray) -> tuple[list[Cause], dict[str, np.ndarray]]:
    """The causes table: one row per column, each shrink for that effect alone added to the base.

    ``shrink_beyond_base`` is the same out-of-sample error against the base alone's: the
    effect's own part, which can be negative when the effect does worse than the base.
    """
    base_rmse = float(np.sqrt(np.mean(base_errors**2)))
    causes, errors_after = [], {}
    for ev in representatives:
        shrink = estimate_shrink(r, attribution.losses.errors(ev.test), groups, rng)
        errors_after[ev.test.column] = shrink.errors
        causes.append(Cause(
            column=ev.test.column, transform=ev.test.transform, tau=ev.test.tau, evidence=ev.test.bank.evidence,
            p_value=ev.q_value,
            p_raw=ev.test.p_value,
            gain=ev.test.gain, significant=ev.passes, rmse_before=shrink.rmse_before, rmse_after=shrink.rmse_after,
            shrink=shrink.shrink, shrink_ci=(shrink.ci_low, shrink.ci_high), round=ev.round,
            note=attribution.notes.get(ev.test.column),
            shrink_beyond_base=1.0 - shrink.rmse_after / base_rmse if base_rmse > 0 else None,
        ))
    return causes, errors_after


def mark_ties(causes: list[Cause], undecided: list[str],
              compare: Callable[[str, str], PairedComparison]) -> list[Cause]:
    """Mark the causes that cannot be told apart from the top one.

    A significant cause is tied with the top cause when the paired block-bootstrap test of
    their out-of-sample losses (:func:`svrqp.gap.compare.paired_loss_test`) finds no
    difference; the columns the conditional tests could not separate from it (``undecided``)
    are tied as well. The top cause is marked when anything is tied with it.

    Parameters
    ----------
    causes : list of Cause
        Ranked causes table, best first.
    undecided : list of str
        Columns the conditional tests could not tell apart from the top cause.
    compare : callable
        ``compare(top, other)`` → the paired comparison of the two columns' out-of-sample
        losses (the same one the rival checks of the attribution read, where they made it).

    Returns
    -------
    list of Cause
        The table with ``ambiguous`` and ``p_paired`` filled in.
    """
    if not causes or not causes[0].significant:
        return causes
    top, marked = causes[0], [causes[0]]
    for cause in causes[1:]:
        if not (cause.significant or cause.column in undecided):
            marked.append(cause)
            continue
        test = compare(top.column, cause.column)
        tied = test.tied or cause.column in undecided
        note = cause.note
        if test.tied and cause.column not in undecided:
            note = _joined(note, f"fits as well as {top.column} (paired p = {test.p_value:.2g})")
        marked.append(dataclasses.replace(cause, ambiguous=tied, p_paired=test.p_value, note=note))
    tied = [c.column for c in marked[1:] if c.ambiguous and c.column not in undecided]
    if tied:
        marked[0] = dataclasses.replace(top, ambiguous=True, note=_joined(top.note, f"fits as well as {_names(tied)}"))
    elif undecided:
        marked[0] = dataclasses.replace(top, ambiguous=True)
    return marked


def _joined(note: str | None, text: str) -> str:
    return text if not note else f"{note}; {text}"


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


def _verdict(attribution, causes, errors_after, data, baseline, groups, gap, detected,
             base: BaseFit, base_errors: np.ndarray, rng: np.random.Generator) -> tuple[Verdict, GateResult | None]:
    train_groups = data.groups[data.is_train]
    if not detected:
        reason = (f"No gap beyond chance: the real-row RMSE {gap.real_rmse:.3g} is not significantly above the "
                  f"train rows' out-of-sample error ({gap.train_rmse:.3g}) nor the noise ({gap.noise_rmse:.3g}); "
                  "no cause is named.")
        return Verdict(column=None, reason=reason), None
    if attribution.verdict is None:
        if attribution.accepted:  # strong evidence, but for several indistinguishable candidates
            names = [causes[0].column, *attribution.ambiguous]
            reason = (f"{', '.join(names)} explain the gap about equally well and cannot be told apart "
                      "on these data; no single cause is named.")
            return Verdict(column=None, reason=reason, ambiguous_with=names), None
        reason = "No candidate explains the real-row error beyond chance (false-discovery rate "
        reason += (f"{attr.ALPHA:g}, effect floor {attr.MIN_GAIN:.0%} of what a recalibration leaves and "
                   f"{attr.MIN_AMPLITUDE:g}× the noise).")
        return Verdict(column=None, reason=reason), None
    top = causes[0]
    if top.shrink_ci[0] <= 0.0:
        # Significance says the candidate carries information; the interval says whether the
        # real-row error actually shrinks. A verdict must claim both (naming a decoy is worse than null).
        reason = (f"The {_effect_text(top, data.order_name)} passes the significance "
                  f"test (q = {top.p_value:.2g}), but the out-of-sample shrink of the real-row RMSE it brings, "
                  f"{top.shrink:.0%} (95 % CI {top.shrink_ci[0]:.0%} … {top.shrink_ci[1]:.0%}), is not "
                  "distinguishable from zero; no cause is named.")
        return Verdict(column=None, reason=reason), None
    after = errors_after[top.column]
    beyond = top.shrink_beyond_base
    beyond_ci = shrink_interval(base_errors, after, groups, rng)
    if beyond is None or beyond_ci[0] <= 0.0:  # None: the base alone leaves no error to remove
        # The effect must beat the base it is added to, out of sample: the test's gain picks the best
        # variant on all rows, the nested estimate chooses it inside each fold and can lose.
        reason = (f"The {_effect_text(top, data.order_name)} passes the significance "
                  f"test (q = {top.p_value:.2g}), but out of sample it does not shrink the real-row error beyond "
                  f"what the base alone ({base.description}) leaves: {beyond or 0.0:.0%} (95 % CI {beyond_ci[0]:.0%} … "
                  f"{beyond_ci[1]:.0%}); no cause is named.")
        return Verdict(column=None, reason=reason), None
    refit = refit_shrink(data, baseline, effect_columns(data, top.column, top.transform, top.tau, top.evidence))
    residual_gate = gate(after, groups, baseline.train_reference, train_groups)
    reason = (f"The {_effect_text(top, data.order_name)} explains the gap "
              f"(q = {top.p_value:.2g}); adding it shrinks the real-row RMSE by {top.shrink:.0%} out of sample "
              f"(95 % CI {top.shrink_ci[0]:.0%} … {top.shrink_ci[1]:.0%}) — {beyond:.0%} beyond the base alone "
              f"({base.description}; 95 % CI {beyond_ci[0]:.0%} … {beyond_ci[1]:.0%}), which gives {base.shrink:.0%}; "
              + _refit_text(refit, top.column))
    tied = [c.column for c in causes[1:] if c.ambiguous]
    if tied:
        reason += (f" Its fit cannot be told apart from that of {_names(tied)} (paired block-bootstrap test of the "
                   f"out-of-sample losses); the verdict stays on it because {_why_it_stays(attribution, tied)}.")
    return Verdict(column=top.column, reason=reason, transform=top.transform, tau=top.tau, evidence=top.evidence,
                   shrink=top.shrink,
                   shrink_ci=top.shrink_ci, shrink_beyond_base=beyond, shrink_beyond_base_ci=beyond_ci,
                   refit_shrink=refit, rmse_before=top.rmse_before,
                   rmse_after=top.rmse_after, p_value=top.p_value, ambiguous_with=tied), residual_gate


def _refit_text(refit: float | None, column: str) -> str:
    """The verdict's refit of the model family on the train rows, in words (a loss said as one)."""
    if refit is None:
        return f"the model cannot be refitted with it as an input, since {column} is not recorded on every train row."
    if refit < 0:
        return (f"refitting the model on the train rows with it as an input makes the real-row error larger "
                f"({refit:.0%}): what the train rows show of it does not carry over to the real rows.")
    return f"refitting the model with it as an input shrinks it by {refit:.0%}."


def _why_it_stays(attribution: Attribution, tied: list[str]) -> str:
    """Why the verdict stays on the top cause although ``tied`` fit the real rows as well."""
    simpler = [c for c in tied if attribution.decided_by.get(c) == attr.BY_PARAMETERS]
    informed = [c for c in tied if c not in simpler]
    reasons = []
    if informed:
        reasons.append("the conditional tests, on the evidence where the candidates decorrelate, favour it or credit "
                       "each with its own information" + (f" ({_names(informed)})" if simpler else ""))
    if simpler:
        reasons.append(f"it needs fewer parameters than {_names(simpler)} for the same fit (parsimony)")
    return " and ".join(reasons)


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


def _summary(data: GapData, gap: GateResult, detected: bool, where: list[Region], verdict: Verdict,
             exact: bool, inputs: list[InputUse]) -> str:
    """The gap in one sentence: how large, where, what explains it (and a model used beyond its data)."""
    unit = unit_of(data.target)
    if exact:
        return (f"On the {int(data.is_real.sum())} real rows the model reproduces {data.target} exactly (zero "
                "residual): there is no gap and no cause is named.")
    text = (f"On the {int(data.is_real.sum())} real rows the error of {data.target} is "
            f"{_quantity(gap.real_rmse, unit)} RMS against {_quantity(gap.train_rmse, unit)} on the train rows")
    top = where[0] if where else None
    within = next((region for region in where if region.group is not None), None)
    run_part = ("" if within is None else f"within run {within.group} alone at {within.column} {within.low:.4g} … "
                f"{within.high:.4g}, {within.share_of_run:.0%} of that run's")
    if top is not None and top.share < 0.999:
        text += (f"; it concentrates at {top.column} {top.low:.4g} … {top.high:.4g} ({top.share:.0%} of the squared error"
                 + (f"; {run_part})" if run_part else ")"))
    elif run_part:
        text += f"; it concentrates {run_part} squared error"
    if verdict.column is not None:
        text += (f", and the {_effect_text(verdict, data.order_name)} "
                 f"explains it: adding it shrinks the error by {verdict.shrink:.0%} out of sample")
        if verdict.ambiguous_with:
            verb = "explains" if len(verdict.ambiguous_with) == 1 else "explain"
            text += f", though {_names(verdict.ambiguous_with)} {verb} it about as well and cannot be told apart from it"
        text += "."
    elif not detected:
        text += "; it is not beyond the train rows' error or the noise, so no cause is named."
    elif verdict.ambiguous_with:
        text += f"; {_names(verdict.ambiguous_with)} explain it equally well and cannot be told apart."
    else:
        text += "; no candidate explains it beyond chance."
    extrapolated = [u for u in inputs if u.extrapolated]
    if detected and extrapolated:
        worst = max(extrapolated, key=lambda u: u.recalibration_shrink)
        unit = unit_of(worst.column)
        text += (f" The model is used beyond its data: {worst.column} lies outside its train range "
                 f"({_quantity(worst.train_low, None)} … {_quantity(worst.train_high, unit)}) on "
                 f"{worst.outside:.0%} of the real rows")
        offsets = _offsets_text(data)
        # A recalibration that removes nothing is said so, not printed as a negative shrink.
        if worst.beyond_offsets is not None and worst.beyond_offsets <= 0:
            text += f", though recalibrating it removes nothing out of sample beyond what {offsets} alone does."
        elif worst.recalibration_shrink <= 0:
            text += ", though recalibrating it does not reduce the error out of sample."
        else:
            text += f", and recalibrating it alone shrinks the error by {worst.recalibration_shrink:.0%} out of sample"
            if worst.beyond_offsets is not None:
                text += f", {worst.beyond_offsets:.0%} of what {offsets} alone leaves"
            text += "."
    return text
