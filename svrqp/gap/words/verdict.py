"""The verdict and the summary: the one cause the engine stands behind, or none and why, in words.

:func:`decide` applies the contract's rules (``docs/gap.md``) to the ranked causes
(:mod:`svrqp.gap.transfer.ranking`): no gap, no culprit; no culprit when refitting with the same
inputs leaves only noise (:func:`svrqp.gap.detect.refit_closes`); otherwise the best-transferring
significant cause, if its transfer shrink is positive, its shrink beyond the refit (in the
model's own family) is positive and, with enough held-out units, has an interval above zero.
Words read records here, they compute nothing: the engine (:mod:`svrqp.gap.diagnose`) refits
the model with the cause :func:`decide` returns, and :func:`named` words the verdict from it.
The report's summary (:func:`summary`) is here too: at most two sentences and 60 words. It states
the gap against the train rows' error on the same footing, then what fixes it on held-out units:
leading with extrapolation when a model input is used outside its train range and the same-input
refit removes most of the gap (``docs/gap.md``, "The contract"), else the verdict's transfer shrink,
or, without a verdict, whether the evidence was too thin for the best-transferring cause to be
tested at all. :func:`extrapolation_text` is the reason's sentence on extrapolation, and
:func:`effect_label` the effect as the report's before-and-after figure titles it.
"""

from __future__ import annotations

from dataclasses import dataclass

from svrqp.gap.contract import ALPHA, EVIDENCE_BETWEEN, LINEAR, MIN_BLOCKS, MIN_GAIN, THIN_UNITS
from svrqp.gap.data import RISE, GapData
from svrqp.gap.results.records import BaseFit, Cause, GateResult, InputUse, Ranking, Units, Verdict
from svrqp.gap.transfer.windows import region_text
from svrqp.units import probability_relation, quantity, unit_of


@dataclass(frozen=True)
class VerdictContext:
    """What the verdict and the summary read besides the ranking.

    Attributes
    ----------
    data : GapData
        Prepared rows.
    model : str
        The given model's kind (``mlr``, ``svr``, ``lssvr``; ``prediction`` for a prediction
        column): :attr:`svrqp.gap.model.Baseline.kind`.
    offsets : str
        The offsets of the per-run recalibration base in words
        (:func:`svrqp.gap.model.offsets_text`).
    gap : GateResult
        The gate's numbers (train and real RMSE).
    detected : bool
        Whether the gate found a gap.
    base : BaseFit
        What a per-run recalibration fitted on the real rows would remove.
    units : Units
        The held-out units of the transfer refits.
    inputs : list of InputUse
        Every model input and candidate against its train range.
    transfer : dict
        The report's ``transfer`` entry (``rmse_before``, ``rmse_refit``, ``shrink_refit``,
        ``refit_closes_gap``, …). Never changed in place: the cause search builds a new context
        with the refit's numbers (``dataclasses.replace``), so a context is complete or says
        ``None`` for what is not known yet.
    """

    data: GapData
    model: str
    offsets: str
    gap: GateResult
    detected: bool
    base: BaseFit
    units: Units
    inputs: list[InputUse]
    transfer: dict


def refit_text(refit: float | None, column: str, failure: str | None = None) -> str:
    """The verdict's refit of the model family on the train rows, in words (a loss said as one).

    ``failure`` is why its solver could not certify an answer (the refit is then None).
    """
    if failure is not None:
        return ("the model could not be refitted with it as an input: its solver failed "
                f"({failure}).")
    if refit is None:
        return (f"the model cannot be refitted with it as an input, since {column} is not "
                "recorded on every train row.")
    if refit < 0:
        return ("refitting the model on the train rows with it as an input makes the real-row "
                f"error larger ({refit:.0%}): what the train rows show of it does not carry over "
                "to the real rows.")
    return f"refitting the model with it as an input shrinks it by {refit:.0%}."


RISE_WORDS = " since each run's start"
"""What follows ``rise of X``: the lag at τ = ∞, heating since the run began."""


def names(columns: list[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return columns[0] if len(columns) == 1 else f"{', '.join(columns[:-1])} and {columns[-1]}"


def effect_text(effect: Cause | Verdict, order_name: str) -> str:
    """``lag of T4_C (τ = 78.3 min)``, a local effect with its stretch, or a run-level candidate's
    level with how it was tested."""
    if effect.region is not None:
        return f"{effect.column} term {region_text(effect.region)}"
    text = f"{effect.transform} of {effect.column}" + (RISE_WORDS if effect.transform == RISE
                                                       else "")
    if effect.tau is not None:
        text += f" (τ = {quantity(effect.tau, unit_of(order_name))})"
    if effect.evidence == EVIDENCE_BETWEEN:
        text += (f" (constant within each run, scaling a profile along {order_name}; tested "
                 f"between runs)")
    return text


def family_text(cause: Cause, context: VerdictContext) -> str:
    """Which model family the cause's transfer numbers refit,
    when that is not the linear screen (else empty)."""
    transfer = context.transfer
    if transfer["family_note"]:
        return f" The model is {context.model}, but {transfer['family_note']}."
    if transfer["family"] == LINEAR:
        return ""
    if cause.family == LINEAR:
        return (f" These numbers are the linear family's: {cause.column} is recorded on too few "
                f"rows for a "
                f"{transfer['family']} refit without a held-out {unit_word(context.units)}.")
    return (f" These numbers refit the {cause.family} itself, with the given model's C, ε and γ; "
            "the ranking and the transfer test use the linear family.")


def decide(ranking: Ranking, causes: list[Cause], context: VerdictContext) -> Verdict | Cause:
    """The cause the engine stands behind: the best-transferring
    significant one (:mod:`svrqp.gap.transfer.ranking`).

    It must come with a gap (one-sided gate), pass the transfer test, leave the real rows better
    than the given model does (``shrink > 0``), add to the same-input refit of the model's own
    family (``shrink_beyond_refit > 0``: a kernel family may disagree with the linear screen),
    and — with enough held-out units for a bootstrap over them to mean anything
    (:data:`svrqp.gap.contract.THIN_UNITS`) — its shrink beyond the refit must have an interval
    above zero. With thin evidence the reason and the
    summary say so instead.

    Returns
    -------
    Verdict or Cause
        The verdict naming no cause, with its reason; or the cause to name, which the engine
        refits on the train rows before :func:`named` words its verdict.
    """
    data, units = context.data, context.units
    everywhere = [c.column for c in causes if c.significant and c.shrink_beyond_refit > 0]
    unexplained = _no_gap_to_explain(context, everywhere, thin_text(units))
    if unexplained is not None:
        return unexplained
    top = ranking.top
    thin, recalibration = _caveats(ranking, context)

    def no_cause(reason: str) -> Verdict:
        return Verdict(column=None, reason=reason, thin=units.thin,
                       untestable=ranking.untestable)

    if top is None:
        reason = ("No candidate improves the model on held-out runs beyond chance (transfer "
                  f"surrogate test, false-discovery rate {ALPHA:g}, effect floor {MIN_GAIN:.0%} of "
                  f"the refit's squared error).{thin}{recalibration}")
        if ranking.withheld:
            reason = ranking.withheld + thin + recalibration
        return no_cause(reason)
    cause = next(c for c in causes if c.column == top.effect.column)
    if cause.shrink <= 0.0:
        reason = (f"The {effect_text(cause, data.order_name)} passes the transfer test (q "
                  f"{probability_relation(cause.p_value)}) and adds "
                  f"{cause.shrink_beyond_refit:.0%} to a refit, but the refit with it still leaves "
                  f"the real-row error larger than the given model's ({cause.rmse_after:.3g} "
                  f"against {cause.rmse_before:.3g}); no cause is "
                  f"named.{family_text(cause, context)}{thin}{recalibration}")
        return no_cause(reason)
    if cause.shrink_beyond_refit <= 0.0 or (cause.shrink_beyond_refit_ci is not None
                                            and cause.shrink_beyond_refit_ci[0] <= 0.0):
        # Thin evidence excuses the interval, never an
        # effect that leaves the same-input refit no better.
        where = ("" if cause.shrink_beyond_refit <= 0.0
                 else f" on every resample of the held-out {unit_word(units)}s")
        reason = (f"The {effect_text(cause, data.order_name)} passes the transfer test (q "
                  f"{probability_relation(cause.p_value)}), but what it adds to a refit is not "
                  f"above zero{where}: {cause.shrink_beyond_refit:.0%}"
                  f"{interval_text(cause.shrink_beyond_refit_ci, ' (95 % CI ', ')')}; no cause is "
                  f"named.{family_text(cause, context)}{thin}{recalibration}")
        return no_cause(reason)
    return cause


def named(cause: Cause, ranking: Ranking, context: VerdictContext, refit: float | None,
          failure: str | None = None) -> Verdict:
    """The verdict naming ``cause`` (as :func:`decide` returned it), with its reason.

    ``refit`` is the shrink of the model family refitted on the train rows with the cause's
    effect (:func:`svrqp.gap.model.refit_shrink`; None where it cannot be, with ``failure``
    saying why when its solver could not certify an answer).
    """
    data, units = context.data, context.units
    thin, recalibration = _caveats(ranking, context)
    top = ranking.top
    reason = (f"The {effect_text(cause, data.order_name)} transfers: refitting the model with it, "
              f"leave-one-{unit_word(units)}-out over all rows, shrinks the real-row RMSE from "
              f"{cause.rmse_before:.3g} to {cause.rmse_after:.3g} ({cause.shrink:.0%}"
              f"{interval_text(cause.shrink_ci, ', 95 % CI ', '')}), "
              f"{cause.shrink_beyond_refit:.0%} beyond the same refit without it "
              f"({cause.rmse_refit:.3g}{interval_text(cause.shrink_beyond_refit_ci, '; CI ', '')})"
              "; transfer test q "
              f"{probability_relation(cause.p_value)}. "
              + capitalised(refit_text(refit, cause.column, failure)) + family_text(cause, context)
              + thin + recalibration)
    # a level too few runs can permute, tested through its dynamics within runs
    if top.tested_by is not None:
        reason += (" Its run levels are too few for any ordering of them to reach significance; "
                   f"the transfer test is that of its {top.tested_by.effect.transform}, rotated "
                   "within runs (as valid under \"it carries nothing\").")
    if ranking.ambiguous_with:
        reason += (" On held-out runs it cannot be told apart from "
                   f"{names(ranking.ambiguous_with)} (neither adds to the other in a conditional "
                   "transfer test); it stays named because it transfers best.")
    return Verdict(column=cause.column, reason=reason, transform=cause.transform, tau=cause.tau,
                   evidence=cause.evidence, shrink=cause.shrink, shrink_ci=cause.shrink_ci,
                   refit_shrink=refit, rmse_before=cause.rmse_before,
                   rmse_after=cause.rmse_after,
                   p_value=cause.p_value, ambiguous_with=list(ranking.ambiguous_with),
                   rmse_refit=cause.rmse_refit, shrink_beyond_refit=cause.shrink_beyond_refit,
                   shrink_beyond_refit_ci=cause.shrink_beyond_refit_ci, thin=units.thin,
                   family=cause.family, untestable=ranking.untestable,
                   region=cause.region)


def _caveats(ranking: Ranking, context: VerdictContext) -> tuple[str, str]:
    """The sentences every reason about a ranked cause ends with: thin evidence, and what a
    per-run recalibration fitted on the real rows would remove."""
    base = context.base
    recalibration = (f" A per-run recalibration fitted on the real rows themselves "
                     f"({base.description}) would "
                     f"remove {base.shrink:.0%} of the real-row error; no new run gets that.")
    return (ranking.too_thin or "") + thin_text(context.units), recalibration


def _no_gap_to_explain(context: VerdictContext, everywhere: list[str],
                       thin: str) -> Verdict | None:
    """The verdict naming no cause when no gap is detected or the same-input refit closes it."""
    data, gap, units = context.data, context.gap, context.units
    if not context.detected:
        reason = (
            f"No gap: the real-row RMSE {gap.real_rmse:.3g} is "
            f"{'not above' if gap.real_rmse <= gap.train_rmse else 'not significantly above'} "
            f"the train rows' {train_label(data)} error ({gap.train_rmse:.3g}) beyond chance; no "
            "column is named as the gap's cause.")
        if everywhere:
            reason += (f" Adding {names(everywhere)} would still improve the model on held-out "
                       "runs everywhere (see the causes table).")
        return Verdict(column=None, reason=reason, thin=units.thin)
    if context.transfer["refit_closes_gap"]:
        reason = (f"Refitting the model leave-one-{unit_word(units)}-out over all rows, with the "
                  f"same inputs, leaves a real-row RMSE of {context.transfer['rmse_refit']:.3g}, "
                  "no larger than the measurement noise beyond chance: the gap is the model's use "
                  "outside its data, and no column is named as its cause.")
        if everywhere:
            reason += (f" Adding {names(everywhere)} would still improve the refitted model on "
                       f"held-out {unit_word(units)}s everywhere (see the causes table).")
        return Verdict(column=None, reason=reason + thin, thin=units.thin)
    return None


def capitalised(text: str) -> str:
    return text[:1].upper() + text[1:]


def unit_word(units: Units) -> str:
    return "block" if units.kind == "blocks" else "run"


def interval_text(interval: tuple[float, float] | None, before: str, after: str) -> str:
    """``before`` + "low … high" + ``after`` for a 95 % interval; empty where there is none (too few
    units: the thin-evidence sentence says so)."""
    if interval is None:
        return ""
    return f"{before}{interval[0]:.0%} … {interval[1]:.0%}{after}"


def thin_text(units: Units) -> str:
    """The sentence on thin or short transfer evidence (empty when there is none to make)."""
    if units.kind == "blocks" and units.short:
        return (f" The record is too short for {MIN_BLOCKS} blocks as long as the residual stays "
                f"correlated ({units.decorrelation_rows} rows): it is cut into {units.n_units} "
                "shorter blocks, so the transfer numbers are optimistic.")
    if units.thin:
        return (f" Only {units.n_units} held-out {unit_word(units)}s carry the transfer evidence: "
                f"too few for an interval ({THIN_UNITS} or more give one), and one more run could "
                "change it.")
    return ""


def train_label(data: GapData) -> str:
    """How the train-row error was measured: the footing the real rows are compared on."""
    return "prediction" if data.prediction is not None else "cross-validated"


# -- the summary --------------------------------------------------------------------


def summary(context: VerdictContext, verdict: Verdict, exact: bool) -> str:
    """At most two sentences and 60 words: the gap, and what fixes it on held-out runs."""
    data, gap, units, transfer = context.data, context.gap, context.units, context.transfer
    unit = unit_of(data.target)
    n_real = int(data.is_real.sum())
    if exact:
        return (f"On the {n_real} real rows the model reproduces {data.target} exactly: no gap, "
                "no cause named.")
    first = (f"On {n_real} real rows {data.target} is off by {quantity(gap.real_rmse, unit)} RMS "
             f"against {quantity(gap.train_rmse, unit)} {train_label(data)} on the train rows")
    if not context.detected:
        return first + "; that is no gap, so no cause is named."
    held = f"{units.n_units} held-out {unit_word(units)}s"
    caveat = ("; thin evidence" if units.thin else "") + ("; blocks shorter than the error's "
                                                          "correlation"
                                                        if units.kind == "blocks" and units.short
                                                          else "")
    extrapolated = [u for u in context.inputs if u.role == "input" and u.extrapolated]
    refit_gain = transfer["rmse_before"] - (transfer["rmse_refit"] or transfer["rmse_before"])
    if extrapolated and refit_gain >= 0.5 * (gap.real_rmse - gap.train_rmse):
        worst = _most_outside(extrapolated)
        second = (f"The model is used outside its data ({worst.column} on {worst.outside:.0%} of "
                  f"real rows); refitting with the new runs removes {transfer['shrink_refit']:.0%}")
        if verdict.column is not None:
            second += f", adding the {_short_effect(verdict, data.order_name)} {verdict.shrink:.0%}"
        return f"{first}. {second} on {held}" + (f" ({caveat[2:]})." if caveat else ".")
    if verdict.column is not None:
        # the verdict's own family (kernel_transfer)
        refit_alone = 1 - verdict.rmse_refit / verdict.rmse_before
        second = (f"Adding the {_short_effect(verdict, data.order_name)} and refitting shrinks it "
                  f"by {verdict.shrink:.0%} on {held} (refit alone: {refit_alone:.0%}{caveat})")
        if verdict.ambiguous_with:
            second += (f"; {names(verdict.ambiguous_with[:2])} "
                       + ("does" if len(verdict.ambiguous_with) == 1 else "do") + " about as well")
        return f"{first}. {second}."
    if transfer.get("refit_closes_gap"):
        return (f"{first}. Refitting with the new {unit_word(units)}s removes "
                f"{transfer['shrink_refit']:.0%} and "
                f"leaves only noise on {held}, so no cause is named"
                + (f" ({caveat[2:]})." if caveat else "."))
    second = f"{first}. No candidate improves a refit on {held} beyond chance"
    # the evidence is too thin by design (svrqp.gap.results.records.Ranking.too_thin)
    if verdict.untestable is not None:
        return second + (f"; {verdict.untestable}, one level per run, transfers best, but too few "
                         "runs to test it: the evidence is too thin.")
    return second + (f" ({caveat[2:]})." if caveat else ".")


def _most_outside(uses: list[InputUse]) -> InputUse:
    """The input used furthest outside its data: most
    real rows outside, then the largest recalibration."""
    return max(uses, key=lambda u: (u.outside, u.recalibration_shrink))


def _short_effect(verdict: Verdict, order_name: str) -> str:
    """``lag of T1_C (τ 125 min)`` — the verdict's effect in few words."""
    if verdict.region is not None:
        return f"{verdict.column} term {region_text(verdict.region)}"
    text = f"{verdict.transform} of {verdict.column}" + (RISE_WORDS if verdict.transform == RISE
                                                         else "")
    if verdict.evidence == EVIDENCE_BETWEEN:
        return text + " (constant within each run)"
    return text + (f" (τ {quantity(verdict.tau, unit_of(order_name))})" if verdict.tau is not None
                   else "")


def effect_label(v: Verdict) -> str:
    """The verdict's effect as the before-and-after figure
    titles it: ``lag of T4_C (τ = 78.3)``, "TRANSFORM of COLUMN"."""
    if v.region is not None:
        return (f"{v.column} within {v.region['low']:.3g} … {v.region['high']:.3g} "
                f"of {v.region['column']}")
    if v.transform == "lag":
        return f"lag of {v.column} (τ = {v.tau:.3g})"
    if v.transform == RISE:
        return f"rise of {v.column}{RISE_WORDS}"
    return f"{v.transform} of {v.column}"


def extrapolation_text(context: VerdictContext) -> str:
    """The reason's sentence on model inputs used outside their train range (empty when none is)."""
    units, transfer = context.units, context.transfer
    extrapolated = [u for u in context.inputs if u.role == "input" and u.extrapolated]
    if not extrapolated:
        return ""
    worst = _most_outside(extrapolated)
    text = (f" The model is used beyond its data: {worst.column} lies outside its train range "
            f"({quantity(worst.train_low, None)} … "
            f"{quantity(worst.train_high, unit_of(worst.column))}) on {worst.outside:.0%} of the "
            f"real rows; refitting leave-one-{unit_word(units)}-out over all rows "
            + (f"removes {transfer['shrink_refit']:.0%} of the real-row error"
               if transfer["shrink_refit"] > 0
               else f"does not reduce the real-row error (the held-out {unit_word(units)}s lie "
                    "outside the others' range too)"))
    offsets = context.offsets
    if worst.beyond_offsets is not None and worst.beyond_offsets <= 0:
        return text + (", and recalibrating it removes nothing out of sample beyond what "
                       f"{offsets} alone does.")
    if worst.recalibration_shrink <= 0:
        return text + (", and recalibrating it on the real rows does not reduce the error out of "
                       "sample.")
    text += (", while recalibrating it on the real rows would remove "
             f"{worst.recalibration_shrink:.0%}")
    if worst.beyond_offsets is not None:
        text += f", {worst.beyond_offsets:.0%} of what {offsets} alone leaves"
    return text + "."
