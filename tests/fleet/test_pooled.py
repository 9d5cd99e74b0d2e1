"""The pooled evidence: Fisher's rule against SciPy's, Benjamini–Hochberg against its definition,
its level on fleets where nothing is carried, and its power on an effect weak on every record."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from svrqp.fleet.pooled import (
    ALPHA,
    FLEET_ALPHA,
    METHODS,
    benjamini_hochberg,
    fisher,
    pool,
    wilkinson,
)


def _tests(p: dict[str, np.ndarray]) -> pd.DataFrame:
    rows = [{"name": f"m{k}", "column": column, "transform": "level", "gain": 0.0,
             "tested": value < 1.0, "p_raw": value}
            for column, values in p.items() for k, value in enumerate(values)]
    return pd.DataFrame(rows)


def test_fisher_is_scipys_combination():
    p = np.random.default_rng(0).uniform(size=17)
    assert fisher(p) == pytest.approx(stats.combine_pvalues(p, method="fisher").pvalue, rel=1e-12)
    assert fisher(np.ones(5)) == pytest.approx(1.0)
    assert fisher(np.array([])) == 1.0


def test_wilkinson_is_the_binomial_test_of_the_count():
    p = np.random.default_rng(3).uniform(0.0, 0.3, size=40)
    count = int((p <= ALPHA).sum())
    expected = stats.binomtest(count, 40, ALPHA, alternative="greater").pvalue
    assert wilkinson(p) == pytest.approx(expected, rel=1e-10)
    assert wilkinson(np.ones(9)) == 1.0 and wilkinson(np.array([])) == 1.0


def test_benjamini_hochberg_by_its_definition():
    p = np.array([0.01, 0.04, 0.03, 0.5, 0.002])
    m = p.size
    expected = [min(min(p[j] * m / (np.sum(p <= p[j])) for j in range(m) if p[j] >= p[i]), 1.0)
                for i in range(m)]
    np.testing.assert_allclose(benjamini_hochberg(p), expected, rtol=1e-12)


@pytest.mark.parametrize("untested", [0.0, 1 / 3])
@pytest.mark.parametrize("method", METHODS)
def test_nothing_is_named_beyond_the_level_on_null_fleets(method, untested):
    """Uniform p-values, a share of them untested (p = 1): at most FLEET_ALPHA of the fleets name
    a candidate (with the binomial's 3-sigma slack over 300 fleets). With every record tested,
    Fisher's pool is at its level, so at a record's own 5 % it fails here; Wilkinson's discrete
    count stays below its level, and untested records (p = 1) make either more conservative."""
    rng = np.random.default_rng(1)
    named = 0
    for _ in range(300):
        p = rng.uniform(size=(4, 40))
        p[rng.uniform(size=p.shape) < untested] = 1.0
        named += bool(pool(_tests({f"c{i}": p[i] for i in range(4)}), method).named)
    assert named / 300 <= FLEET_ALPHA + 3 * np.sqrt(FLEET_ALPHA * (1 - FLEET_ALPHA) / 300)


@pytest.mark.parametrize("method", METHODS)
def test_an_effect_weak_on_every_record_is_named_with_its_carriers(method):
    rng = np.random.default_rng(2)
    weak = np.concatenate([rng.beta(0.5, 3.0, size=12), rng.uniform(size=28)])  # 30 % carry it
    assert (weak[:12] > 0.01).sum() >= 6  # most carriers are no discovery on their own
    verdict = pool(_tests({"weak": weak, "decoy": rng.uniform(size=40)}), method)
    assert verdict.named[0] == "weak"  # (the decoy's own level is the null test's)
    assert set(verdict.carriers["weak"]) == {f"m{k}" for k in np.flatnonzero(weak <= ALPHA)}
    assert "weak" in verdict.summary()


def test_untested_records_weaken_fisher_but_not_the_count():
    """Eight of forty records find the effect at p = 0.01, the rest leave it untested (p = 1)."""
    p = np.r_[np.full(8, 0.01), np.ones(32)]
    assert wilkinson(p) < 0.01 < fisher(p)


def test_an_empty_fleet_names_nothing():
    verdict = pool(pd.DataFrame(columns=["name", "column", "transform", "gain", "tested",
                                         "p_raw"]))
    assert verdict.named == [] and "no candidate" in verdict.summary()
