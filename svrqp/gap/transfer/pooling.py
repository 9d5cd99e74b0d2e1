r"""Every candidate's transfer test, for evidence pooled over many records (``svrqp fleet``).

A diagnosis tests by transfer only the causes whose transfer gain clears the effect floor
(:data:`svrqp.gap.contract.MIN_GAIN`, :meth:`svrqp.gap.transfer.ranking.TransferRanker.test`):
below it, an effect is too small to *name* on one record, whatever its p-value. Over a fleet,
an effect that stays below the floor on every machine can still recur on many of them, and
only the records' p-values can show it. :func:`pool_p_values` gives one p-value per candidate:

- the record's own ``p_raw`` when the record tested the column;
- otherwise the same test (:meth:`~svrqp.gap.transfer.ranking.TransferRanker.p_value`: the
  column's best-transferring transform against surrogates of it — rotations within runs,
  permutations of run levels, exact over few runs, or the t-test between runs where the record
  would use it) drawn on **its own surrogate stream** (``(seed, POOL_STREAM)``), at most
  :data:`POOL_SURROGATES` surrogates.

It runs after the diagnosis has decided everything, on a copy of the ranker that draws from the
pool's stream only: the record's causes, verdict and JSON are those of the diagnosis without it,
bit for bit. A candidate whose best form is local (a window) has no pooled p-value, as it has no
row in the fleet's tests (:func:`svrqp.fleet.table.tests_of`).
"""

from __future__ import annotations

import copy

import numpy as np

from svrqp.gap.results.records import Ranked
from svrqp.gap.transfer.ranking import TransferRanker
from svrqp.gap.transfer.surrogates import TransferSurrogates

POOL_STREAM = 21
"""The pool's surrogate stream, ``numpy.random.default_rng([seed, POOL_STREAM])`` (the
diagnosis draws from ``[seed, 19]`` and ``[seed, 20]``)."""

POOL_SURROGATES = 199
"""Most surrogates of one pooled test (smallest p-value 1/200): enough for a combination over
records, where each record's evidence is weak, at a fifth of a record's own test."""


def pool_p_values(ranker: TransferRanker, ranked: list[Ranked], seed: int) -> dict[str, float]:
    """One transfer-test p-value per candidate column (module docstring), best first.

    Parameters
    ----------
    ranker : TransferRanker
        The diagnosis' ranker, after its tests and choice (it is not changed).
    ranked : list of Ranked
        Its ranked rows (one per column, its best-transferring transform).
    seed : int
        The diagnosis' seed.

    Returns
    -------
    dict
        Column -> p-value.
    """
    rng = np.random.default_rng([seed, POOL_STREAM])
    probe = copy.copy(ranker)
    probe.local_rng = rng.spawn(1)[0]
    probe.surrogates = TransferSurrogates(ranker.data, ranker.family.A, rng, probe.local_rng,
                                          lift=ranker.family.units.kind == "blocks")
    p_values: dict[str, float] = {}
    for row in ranked:
        column = row.effect.column
        if row.effect.windows is not None or column in p_values:
            continue
        if row.tested:
            p_values[column] = float(row.p_raw)
        elif probe.parametric(row.effect, len(ranked)):
            p_values[column] = float(probe.between_p(row.effect))
        else:
            test = row.tested_by or row
            p_values[column] = float(probe.p_value(test.effect, test.gain, POOL_SURROGATES))
    return p_values
