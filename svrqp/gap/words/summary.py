"""The report's summary: at most two sentences and 60 words, and the reason's sentence on extrapolation.

The summary states the gap against the train rows' error on the same footing, then what fixes it
on held-out units: leading with extrapolation when a model input is used outside its train range
and the same-input refit removes most of the gap (``docs/gap.md``, "The contract"), else the verdict's transfer shrink,
or, without a verdict, whether the evidence was too thin for the best-transferring cause to be tested at all.
"""

from __future__ import annotations

from svrqp.gap.contract import EVIDENCE_BETWEEN
from svrqp.gap.model.recalibration import offsets_text
from svrqp.gap.results.records import InputUse, Verdict
from svrqp.gap.transfer.windows import region_text
from svrqp.gap.words.figures import quantity, unit_of
from svrqp.gap.words.verdict import VerdictContext, names, train_label, unit_word


def summary(context: VerdictContext, verdict: Verdict, exact: bool) -> str:
    """At most two sentences and 60 words: the gap, and what fixes it on held-out runs."""
    data, gap, units, transfer = context.data, context.gap, context.units, context.transfer
    unit = unit_of(data.target)
    n_real = int(data.is_real.sum())
    if exact:
        return f"On the {n_real} real rows the model reproduces {data.target} exactly: no gap, no cause named."
    first = (f"On {n_real} real rows {data.target} is off by {quantity(gap.real_rmse, unit)} RMS against "
             f"{quantity(gap.train_rmse, unit)} {train_label(data)} on the train rows")
    if not context.detected:
        return first + "; that is no gap, so no cause is named."
    held = f"{units.n_units} held-out {unit_word(units)}s"
    caveat = ("; thin evidence" if units.thin else "") + ("; blocks shorter than the error's correlation"
                                                        if units.kind == "blocks" and units.short else "")
    extrapolated = [u for u in context.inputs if u.role == "input" and u.extrapolated]
    refit_gain = transfer["rmse_before"] - (transfer["rmse_refit"] or transfer["rmse_before"])
    if extrapolated and refit_gain >= 0.5 * (gap.real_rmse - gap.train_rmse):
        worst = _most_outside(extrapolated)
        second = (f"The model is used outside its data ({worst.column} on {worst.outside:.0%} of real rows); "
                  f"refitting with the new runs removes {transfer['shrink_refit']:.0%}")
        if verdict.column is not None:
            second += f", adding the {_short_effect(verdict, data.order_name)} {verdict.shrink:.0%}"
        return f"{first}. {second} on {held}" + (f" ({caveat[2:]})." if caveat else ".")
    if verdict.column is not None:
        refit_alone = 1 - verdict.rmse_refit / verdict.rmse_before  # the verdict's own family (kernel_transfer)
        second = (f"Adding the {_short_effect(verdict, data.order_name)} and refitting shrinks it by {verdict.shrink:.0%} on "
                  f"{held} (refit alone: {refit_alone:.0%}{caveat})")
        if verdict.ambiguous_with:
            second += (f"; {names(verdict.ambiguous_with[:2])} "
                       + ("does" if len(verdict.ambiguous_with) == 1 else "do") + " about as well")
        return f"{first}. {second}."
    if transfer.get("refit_closes_gap"):
        return (f"{first}. Refitting with the new {unit_word(units)}s removes {transfer['shrink_refit']:.0%} and "
                f"leaves only noise on {held}, so no cause is named" + (f" ({caveat[2:]})." if caveat else "."))
    second = f"{first}. No candidate improves a refit on {held} beyond chance"
    if verdict.untestable is not None:  # the evidence is too thin by design (svrqp.gap.results.records.Ranking.too_thin)
        return second + (f"; {verdict.untestable}, one level per run, transfers best, but too few runs to test it: "
                         "the evidence is too thin.")
    return second + (f" ({caveat[2:]})." if caveat else ".")


def _most_outside(uses: list[InputUse]) -> InputUse:
    """The input used furthest outside its data: most real rows outside, then the largest recalibration."""
    return max(uses, key=lambda u: (u.outside, u.recalibration_shrink))


def _short_effect(verdict: Verdict, order_name: str) -> str:
    """``lag of T1_C (τ 125 min)`` — the verdict's effect in few words."""
    if verdict.region is not None:
        return f"{verdict.column} term {region_text(verdict.region)}"
    text = f"{verdict.transform} of {verdict.column}"
    if verdict.evidence == EVIDENCE_BETWEEN:
        return text + " (constant within each run)"
    return text + (f" (τ {quantity(verdict.tau, unit_of(order_name))})" if verdict.tau is not None else "")


def extrapolation_text(context: VerdictContext) -> str:
    """The reason's sentence on model inputs used outside their train range (empty when none is)."""
    data, units, transfer = context.data, context.units, context.transfer
    extrapolated = [u for u in context.inputs if u.role == "input" and u.extrapolated]
    if not extrapolated:
        return ""
    worst = _most_outside(extrapolated)
    text = (f" The model is used beyond its data: {worst.column} lies outside its train range "
            f"({quantity(worst.train_low, None)} … {quantity(worst.train_high, unit_of(worst.column))}) on "
            f"{worst.outside:.0%} of the real rows; refitting leave-one-{unit_word(units)}-out over all rows "
            + (f"removes {transfer['shrink_refit']:.0%} of the real-row error" if transfer["shrink_refit"] > 0
               else f"does not reduce the real-row error (the held-out {unit_word(units)}s lie outside the others' "
                    "range too)"))
    offsets = offsets_text(data)
    if worst.beyond_offsets is not None and worst.beyond_offsets <= 0:
        return text + f", and recalibrating it removes nothing out of sample beyond what {offsets} alone does."
    if worst.recalibration_shrink <= 0:
        return text + ", and recalibrating it on the real rows does not reduce the error out of sample."
    text += f", while recalibrating it on the real rows would remove {worst.recalibration_shrink:.0%}"
    if worst.beyond_offsets is not None:
        text += f", {worst.beyond_offsets:.0%} of what {offsets} alone leaves"
    return text + "."
