r"""Every candidate's transfer test, for evidence pooled over many records (``svrqp fleet``).

A diagnosis tests by transfer only the causes whose transfer gain clears the effect floor
(:data:`svrqp.gap.contract.MIN_GAIN`, :meth:`svrqp.gap.transfer.ranking.TransferRanker.test`):
below it, an effect is too small to *name* on one record, whatever its p-value. Over a fleet,
an effect that stays below the floor on every machine can still recur on many of them, and
only the records' p-values can show it. :func:`pool_p_values` gives one p-value per candidate,
for every candidate, tested by the record or not: the transfer test of
:meth:`~svrqp.gap.transfer.ranking.TransferRanker.p_value` (the column refitted
leave-one-unit-out against surrogates of it: rotations within runs, permutations of run levels,
exact over few runs, or the t-test between runs where the record would use it), drawn on **its
own surrogate stream** (``(seed, POOL_STREAM)``), at most :data:`POOL_SURROGATES` surrogates.

**One form, fixed in advance.** The record ranks each column by its best-transferring form
(level, rate, rise, lag) and tests that one; its observed gain is the best of four while each
surrogate's is the chosen form's, so below the floor its p-value is too small: on five
simulated fleets with nothing withheld, 9 % of 600 of them were at or below 0.05 and Fisher's
rule named a candidate in one fleet of five (a record's own verdict needs the effect floor too,
which keeps that selection harmless there). The pool therefore tests one form chosen before
looking at the data: ``lag`` (the column and its first-order lags, the time constant chosen
inside every fit, surrogates' too), which holds a level and a delayed response; a column with
no ``lag`` form (a run-level candidate constant within runs) is tested by its plain ``level``.

**Beyond its best rival.** Candidates measured on one machine are not independent: other
temperatures follow the same programme as the nut, and a proxy of the withheld effect transfers a
part of it. A record's own verdict checks a rival by conditional tests; pooled over hundreds of
records without that check, every proxy of the effect was named with it (on a fleet of 200 whose
nut heating was weak, all four candidates). So a candidate that is not the record's best (by
its pooled form's transfer gain) and whose p-value is at most :data:`RIVAL_CHECK` is also tested
*given the record's best* (that candidate's form, its time constant fixed at the one its fits
chose most, in the family's inputs; surrogates of the candidate only, as
:meth:`~svrqp.gap.transfer.ranking.TransferRanker.adds` does), and its pooled p-value is the
larger of the two. Either way the pooled p-value is at least the plain test's, so it stays a
valid p-value of "the candidate carries nothing"; a proxy that transfers only what the record's
best carries adds nothing beyond it, and enters with a p-value like a null's.

It runs after the diagnosis has decided everything, on a copy of the ranker that draws from the
pool's stream only: the record's causes, verdict and JSON are those of the diagnosis without it,
bit for bit.
"""

from __future__ import annotations

import copy

import numpy as np

from svrqp.gap.results.records import Effect, Ranked
from svrqp.gap.transfer.ranking import TransferRanker
from svrqp.gap.transfer.surrogates import TransferSurrogates

POOL_STREAM = 21
"""The pool's surrogate stream, ``numpy.random.default_rng([seed, POOL_STREAM])`` (the
diagnosis draws from ``[seed, 19]`` and ``[seed, 20]``)."""

POOL_SURROGATES = 199
"""Most surrogates of one pooled test (smallest p-value 1/200): enough for a combination over
records, where each record's evidence is weak, at a fifth of a record's own test."""

RIVAL_CHECK = 0.2
"""A candidate behind the record's best with a p-value at most this is tested beyond it too
(above it, its p-value is already unremarkable, and the check's cost is saved)."""

POOL_FORMS = ("lag", "level")
"""The form each column is tested in for the pool, the first it has."""


def pooled_form(effects: list[Effect], column: str) -> Effect | None:
    """The effect of ``column`` the pool tests (:data:`POOL_FORMS`; None when it has neither)."""
    forms = {e.transform: e for e in effects
             if e.column == column and e.windows is None and not e.block}
    return next((forms[name] for name in POOL_FORMS if name in forms), None)


def pool_p_values(ranker: TransferRanker, seed: int) -> dict[str, float]:
    """One transfer-test p-value per candidate column (module docstring).

    Parameters
    ----------
    ranker : TransferRanker
        The diagnosis' ranker, after its tests and choice (it is not changed).
    seed : int
        The diagnosis' seed.

    Returns
    -------
    dict
        Column -> p-value, in the order of the candidates.
    """
    rng = np.random.default_rng([seed, POOL_STREAM])
    probe = copy.copy(ranker)
    probe.local_rng = rng.spawn(1)[0]
    probe.surrogates = TransferSurrogates(ranker.data, ranker.family.A, rng, probe.local_rng,
                                          lift=ranker.family.units.kind == "blocks")
    effects = ranker.effects()
    forms = {c: e for c in ranker.data.candidates if (e := pooled_form(effects, c)) is not None}
    fitted = {c: Ranked(e, fit := probe.fit(e), probe.gain(fit), tau=e.chosen_tau(fit.variant))
              for c, e in forms.items()}
    best = max(fitted.values(), key=lambda r: r.gain, default=None)
    p_values: dict[str, float] = {}
    for column, row in fitted.items():
        if probe.parametric(row.effect, len(ranker.data.candidates)):
            p = float(probe.between_p(row.effect))
        else:
            p = float(probe.p_value(row.effect, row.gain, POOL_SURROGATES))
        if best is not row and p <= RIVAL_CHECK:
            p = max(p, _beyond(probe, row, best))
        p_values[column] = p
    return p_values


def _beyond(probe: TransferRanker, row: Ranked, rival: Ranked) -> float:
    """The p-value of ``row``'s gain with ``rival`` already in the family's inputs, against
    surrogates of ``row``'s column (as :meth:`TransferRanker.adds`)."""
    observed, given, reference = probe.given(row.effect, rival)
    return float(probe.p_value(row.effect, observed, POOL_SURROGATES, given, reference))
