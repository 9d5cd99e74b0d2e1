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

It runs after the diagnosis has decided everything, on a copy of the ranker that draws from the
pool's stream only: the record's causes, verdict and JSON are those of the diagnosis without it,
bit for bit.
"""

from __future__ import annotations

import copy

import numpy as np

from svrqp.gap.results.records import Effect
from svrqp.gap.transfer.ranking import TransferRanker
from svrqp.gap.transfer.surrogates import TransferSurrogates

POOL_STREAM = 21
"""The pool's surrogate stream, ``numpy.random.default_rng([seed, POOL_STREAM])`` (the
diagnosis draws from ``[seed, 19]`` and ``[seed, 20]``)."""

POOL_SURROGATES = 199
"""Most surrogates of one pooled test (smallest p-value 1/200): enough for a combination over
records, where each record's evidence is weak, at a fifth of a record's own test."""

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
    p_values: dict[str, float] = {}
    for column in ranker.data.candidates:
        effect = pooled_form(effects, column)
        if effect is None:
            continue
        if probe.parametric(effect, len(ranker.data.candidates)):
            p_values[column] = float(probe.between_p(effect))
        else:
            gain = probe.gain(probe.fit(effect))
            p_values[column] = float(probe.p_value(effect, gain, POOL_SURROGATES))
    return p_values
