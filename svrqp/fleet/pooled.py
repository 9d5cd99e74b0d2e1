r"""Pooled evidence: what no single record can show, from the transfer tests of many.

Each record's diagnosis tests each of its candidates by transfer (:mod:`svrqp.gap.transfer`):
``p_raw`` of its ``causes``, the surrogate test's p-value before the record's own
false-discovery control. For a candidate :math:`c` tested over the :math:`K_c` records that
list it, the rule is **Fisher's**:

.. math::

   X_c = -2 \sum_{k=1}^{K_c} \ln p_{k,c} \sim \chi^2_{2K_c}
   \quad\text{under "no record carries } c\text{"},

the records being independent machines. A record that did not test the column (its transfer
gain below the effect floor of :mod:`svrqp.gap.contract`) enters with :math:`p = 1`, which adds
nothing to :math:`X_c`: each :math:`p_{k,c}` is then at least as large as a valid p-value, so
the pooled test keeps its level (it is conservative) however many records leave it untested.
The pooled p-values of all candidates are then adjusted by **Benjamini–Hochberg** (false
discovery rate :data:`ALPHA` over the candidates) and the fleet names every candidate whose
q-value is below it, best first. The records that *carry* a named candidate are those whose own
test of it is at :math:`p \le` :data:`ALPHA` (before the record's own false-discovery
control): the machines to look at first.

Fisher's null is "no machine carries the effect"; a candidate named by the fleet is carried by
at least one machine, and the count of carrying records (against :math:`\alpha K_c` expected by
chance) says how common it is.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import stats

#: The false-discovery rate over candidates, the same level as a record's own (DESIGN §4).
ALPHA = 0.05
RULE = "Fisher over records, Benjamini-Hochberg over candidates"


@dataclass(frozen=True)
class PooledVerdict:
    """The fleet's answer: the pooled table (one row per candidate) and the candidates named."""

    table: pd.DataFrame
    named: list[str] = field(default_factory=list)
    carriers: dict[str, list[str]] = field(default_factory=dict)
    rule: str = RULE

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


def pool(tests: pd.DataFrame) -> PooledVerdict:
    """The fleet's pooled verdict from the per-record tests (:func:`svrqp.fleet.table.tests_of`).

    ``tests`` has one row per record and candidate: ``name``, ``column``, ``tested``, ``p_raw``
    (1 where not tested) and ``gain``.
    """
    columns = ["column", "records", "tested", "carriers", "median_gain", "p_pooled", "q_value",
               "named"]
    if tests.empty:
        return PooledVerdict(pd.DataFrame(columns=columns))
    rows = []
    for column, part in tests.groupby("column", sort=True):
        p = part["p_raw"].to_numpy(float)
        rows.append({"column": column, "records": len(part), "tested": int(part["tested"].sum()),
                     "carriers": int((p <= ALPHA).sum()),
                     "median_gain": float(part["gain"].median()), "p_pooled": fisher(p)})
    table = pd.DataFrame(rows)
    table["q_value"] = benjamini_hochberg(table["p_pooled"].to_numpy())
    table["named"] = table["q_value"] < ALPHA
    table = table.sort_values(["q_value", "p_pooled", "column"], kind="stable")
    table = table.reset_index(drop=True)[columns]
    named = table.loc[table["named"], "column"].tolist()
    carriers = {c: sorted(tests.loc[(tests["column"] == c) & (tests["p_raw"] <= ALPHA),
                                    "name"].tolist()) for c in named}
    return PooledVerdict(table, named, carriers)
