r"""Pooled evidence: what no single record can show, from the transfer tests of many.

Each record's diagnosis tests its candidates by transfer (:mod:`svrqp.gap.transfer`), but only
those whose transfer gain clears the effect floor (:mod:`svrqp.gap.contract`): below it an
effect is too small to *name* on one record. A fleet's record also gives, for every candidate,
``p_pool`` (:mod:`svrqp.gap.transfer.pooling`): the record's own test's ``p_raw`` where it
tested the column, else the same test drawn on its own surrogate stream after the diagnosis
(the record's answer unchanged). Each :math:`p_{k,c}` is a valid p-value of "record :math:`k`
does not carry :math:`c`", below the floor too. For a candidate :math:`c` listed by :math:`K_c`
records (independent machines), the null is "no record carries :math:`c`", and the rule is:

``fisher`` (the default): :math:`X_c = -2 \sum_k \ln p_{k,c}`,
:math:`p_c = P(\chi^2_{2K_c} \ge X_c)` (Fisher's method). It adds every record's evidence,
however weak: an effect that moves each carrier's p-value only a little, on many carriers, adds
up. The Monte-Carlo p-values are at least as large as uniform ones under the null, so
:math:`X_c` is at most a :math:`\chi^2_{2K_c}` and the rule keeps its level.

``wilkinson``: the **count** of records whose test rejects at level :data:`ALPHA`,
:math:`N_c = \#\{k : p_{k,c} \le \alpha\}`, against the binomial,
:math:`p_c = P\big(\mathrm{Bin}(K_c, \alpha) \ge N_c\big)` (Wilkinson's method): it asks
whether the effect is *significant* on more machines than chance would give, and ignores the
p-values between :math:`\alpha` and 1, so it needs an effect a record's test can reject.

The pooled p-values of all candidates are adjusted by **Benjamini–Hochberg** (false discovery
rate :data:`FLEET_ALPHA` over the candidates) and the fleet names every candidate whose q-value is
below it, best first. That level is stricter than a record's own (:data:`ALPHA`): a fleet verdict
says an effect recurs on a machine type, the ground for changing the compensation of every
machine of it, and with nothing carried it names something in about :data:`FLEET_ALPHA` of fleets
(one in 100, where 5 % would name something in about two of three sets of 20 null fleets).
The records that *carry* a named candidate are those whose own
:math:`p_{k,c} \le \alpha` (about :math:`\alpha K_c` of them by chance alone): the machines to
look at first; below the floor a carrier's p-value is often above :math:`\alpha`, so the pooled
verdict can name an effect on more machines than it lists. Both p-values are in the pooled
table (``p_fisher``, ``p_wilkinson``), with ``tested``, the records whose own diagnosis tested
the column.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import stats

from svrqp.exceptions import ProblemError

#: A record's own level (DESIGN §4): the p-value at which a record is listed as a carrier.
ALPHA = 0.05
#: The false-discovery rate over candidates at which the fleet names an effect (module docstring).
FLEET_ALPHA = 0.01
#: The combination rules over records (:func:`pool`'s ``method``), the default first.
METHODS = ("fisher", "wilkinson")
RULES = {"fisher": "Fisher over records' transfer tests, below the effect floor too; "
                   "Benjamini-Hochberg over candidates",
         "wilkinson": "Wilkinson's count over records, Benjamini-Hochberg over candidates"}


@dataclass(frozen=True)
class PooledVerdict:
    """The fleet's answer: the pooled table (one row per candidate) and the candidates named."""

    table: pd.DataFrame
    named: list[str] = field(default_factory=list)
    carriers: dict[str, list[str]] = field(default_factory=dict)
    rule: str = RULES["fisher"]

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
    """Benjamini–Hochberg q-values (step-up, monotone, capped at 1): SciPy's
    ``false_discovery_control``, as the diagnosis adjusts its own (an empty array for none)."""
    p = np.asarray(p_values, dtype=float)
    return p if p.size == 0 else stats.false_discovery_control(p, method="bh")


def pool(tests: pd.DataFrame, method: str = "fisher") -> PooledVerdict:
    """The fleet's pooled verdict from the per-record tests (:func:`svrqp.fleet.table.tests_of`).

    ``tests`` has one row per record and candidate: ``name``, ``column``, ``tested``, ``gain``
    and ``p_pool`` (without it, ``p_raw``: 1 where the record did not test the column). ``method``
    is one of :data:`METHODS`; its p-value is ``p_pooled``, the one adjusted over candidates.
    """
    if method not in METHODS:
        raise ProblemError(f"pooled evidence: method must be one of {', '.join(METHODS)}, got "
                           f"{method!r}")
    columns = ["column", "records", "tested", "carriers", "median_gain", "p_wilkinson",
               "p_fisher", "p_pooled", "q_value", "named"]
    if tests.empty:
        return PooledVerdict(pd.DataFrame(columns=columns), rule=RULES[method])
    p_column = "p_pool" if "p_pool" in tests.columns else "p_raw"
    rows = []
    for column, part in tests.groupby("column", sort=True):
        p = part[p_column].to_numpy(float)
        rows.append({"column": column, "records": len(part), "tested": int(part["tested"].sum()),
                     "carriers": int((p <= ALPHA).sum()),
                     "median_gain": float(part["gain"].median()), "p_wilkinson": wilkinson(p),
                     "p_fisher": fisher(p)})
    table = pd.DataFrame(rows)
    table["p_pooled"] = table[f"p_{method}"]
    table["q_value"] = benjamini_hochberg(table["p_pooled"].to_numpy())
    table["named"] = table["q_value"] < FLEET_ALPHA
    table = table.sort_values(["q_value", "p_pooled", "column"], kind="stable")
    table = table.reset_index(drop=True)[columns]
    named = table.loc[table["named"], "column"].tolist()
    carriers = {c: sorted(tests.loc[(tests["column"] == c) & (tests[p_column] <= ALPHA),
                                    "name"].tolist()) for c in named}
    return PooledVerdict(table, named, carriers, RULES[method])
