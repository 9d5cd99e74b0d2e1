r"""Pooled evidence: what no single record can show, from the transfer tests of many.

Each record's diagnosis tests each of its candidates by transfer (:mod:`svrqp.gap.transfer`):
``p_raw`` of its ``causes``, the surrogate test's p-value before the record's own
false-discovery control. A record that did not test the column (its transfer gain below the
effect floor of :mod:`svrqp.gap.contract`) enters with :math:`p = 1`: each :math:`p_{k,c}` is
then at least as large as a valid p-value, so both rules below keep their level however many
records leave a column untested. For a candidate :math:`c` listed by :math:`K_c` records
(independent machines), the null is "no record carries :math:`c`", and the rule is one of:

``wilkinson`` (the default): the **count** of records whose own test rejects at level
:data:`ALPHA`, :math:`N_c = \#\{k : p_{k,c} \le \alpha\}`. Under the null each record rejects
with probability at most :math:`\alpha`, so :math:`N_c` is stochastically no larger than a
binomial, and

.. math::

   p_c = P\big(\mathrm{Bin}(K_c, \alpha) \ge N_c\big)

(Wilkinson's method). It answers the fleet's question — does the effect *recur*, on more
machines than chance would give? — and neither one strong record nor the untested records
(which only lower :math:`N_c`) move it much.

``fisher``: :math:`X_c = -2 \sum_k \ln p_{k,c}`, :math:`p_c = P(\chi^2_{2K_c} \ge X_c)`. It
weighs how small each p-value is, so one record with a strong effect can carry it (its null
is the same, its answer "at least one machine"), and every untested record, entering with
:math:`p = 1`, adds degrees of freedom and nothing to :math:`X_c`: on effects that few records
test it is the weaker rule.

The pooled p-values of all candidates are adjusted by **Benjamini–Hochberg** (false discovery
rate :data:`ALPHA` over the candidates) and the fleet names every candidate whose q-value is
below it, best first. The records that *carry* a named candidate are those whose own test of it
is at :math:`p \le \alpha` (about :math:`\alpha K_c` of them by chance alone): the machines to
look at first. Both p-values are in the pooled table (``p_wilkinson``, ``p_fisher``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import stats

from svrqp.exceptions import ProblemError

#: The false-discovery rate over candidates, the same level as a record's own (DESIGN §4).
ALPHA = 0.05
#: The combination rules over records (:func:`pool`'s ``method``).
METHODS = ("wilkinson", "fisher")
RULES = {"wilkinson": "Wilkinson's count over records, Benjamini-Hochberg over candidates",
         "fisher": "Fisher over records, Benjamini-Hochberg over candidates"}


@dataclass(frozen=True)
class PooledVerdict:
    """The fleet's answer: the pooled table (one row per candidate) and the candidates named."""

    table: pd.DataFrame
    named: list[str] = field(default_factory=list)
    carriers: dict[str, list[str]] = field(default_factory=dict)
    rule: str = RULES["wilkinson"]

    def summary(self) -> str:
        """One sentence: what the fleet names, on how many records."""
        if not self.named:
            return (f"Pooled over the fleet ({self.rule}), no candidate is carried beyond "
                    f"chance.")
        rows = self.table.set_index("column")
        parts = [f"{c} (q = {rows.at[c, 'q_value']:.2g}; {len(self.carriers[c])} of "
                 f"{int(rows.at[c, 'records'])} records at p <= {ALPHA})" for c in self.named]
        return f"Pooled over the fleet ({self.rule}): " + "; ".join(parts) + "."


def fisher(p_values: np.ndarray) -> float:
    """Fisher's combined p-value of independent p-values (1 for none)."""
    p = np.clip(np.asarray(p_values, dtype=float), np.finfo(float).tiny, 1.0)
    if p.size == 0:
        return 1.0
    return float(stats.chi2.sf(-2.0 * np.log(p).sum(), 2 * p.size))


def wilkinson(p_values: np.ndarray, alpha: float = ALPHA) -> float:
    """Wilkinson's combined p-value: the binomial tail of the count of p-values at or below
    ``alpha`` (1 for none)."""
    p = np.asarray(p_values, dtype=float)
    if p.size == 0:
        return 1.0
    return float(stats.binom.sf(int((p <= alpha).sum()) - 1, p.size, alpha))


def benjamini_hochberg(p_values: np.ndarray) -> np.ndarray:
    """Benjamini–Hochberg q-values (step-up, monotone, capped at 1)."""
    p = np.asarray(p_values, dtype=float)
    if p.size == 0:
        return p
    order = np.argsort(p)
    ranked = p[order] * p.size / np.arange(1, p.size + 1)
    q = np.minimum.accumulate(ranked[::-1])[::-1]
    out = np.empty_like(q)
    out[order] = np.minimum(q, 1.0)
    return out


def pool(tests: pd.DataFrame, method: str = "wilkinson") -> PooledVerdict:
    """The fleet's pooled verdict from the per-record tests (:func:`svrqp.fleet.table.tests_of`).

    ``tests`` has one row per record and candidate: ``name``, ``column``, ``tested``, ``p_raw``
    (1 where not tested) and ``gain``. ``method`` is one of :data:`METHODS`; its p-value is
    ``p_pooled``, the one adjusted over candidates.
    """
    if method not in METHODS:
        raise ProblemError(f"pooled evidence: method must be one of {', '.join(METHODS)}, got "
                           f"{method!r}")
    columns = ["column", "records", "tested", "carriers", "median_gain", "p_wilkinson",
               "p_fisher", "p_pooled", "q_value", "named"]
    if tests.empty:
        return PooledVerdict(pd.DataFrame(columns=columns), rule=RULES[method])
    rows = []
    for column, part in tests.groupby("column", sort=True):
        p = part["p_raw"].to_numpy(float)
        rows.append({"column": column, "records": len(part), "tested": int(part["tested"].sum()),
                     "carriers": int((p <= ALPHA).sum()),
                     "median_gain": float(part["gain"].median()), "p_wilkinson": wilkinson(p),
                     "p_fisher": fisher(p)})
    table = pd.DataFrame(rows)
    table["p_pooled"] = table[f"p_{method}"]
    table["q_value"] = benjamini_hochberg(table["p_pooled"].to_numpy())
    table["named"] = table["q_value"] < ALPHA
    table = table.sort_values(["q_value", "p_pooled", "column"], kind="stable")
    table = table.reset_index(drop=True)[columns]
    named = table.loc[table["named"], "column"].tolist()
    carriers = {c: sorted(tests.loc[(tests["column"] == c) & (tests["p_raw"] <= ALPHA),
                                    "name"].tolist()) for c in named}
    return PooledVerdict(table, named, carriers, RULES[method])
