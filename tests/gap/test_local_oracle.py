"""The suite's permutation test told where a localised effect acts (benchmarks/local_oracle.py)."""

import math

import numpy as np
import pandas as pd
import pytest
from support.benchmark_modules import load_benchmark


@pytest.fixture(scope="module")
def oracle():
    return load_benchmark("local_oracle")


def _record(runs: int, rows: int, seed: int, scale: float, run_constant: bool = False):
    """``runs`` runs of ``rows`` rows; the effect ``scale``·x inside rows 20–39 of every run; run 0 is the train run."""
    rng = np.random.default_rng(seed)
    groups = np.repeat(np.arange(runs), rows)
    t = np.tile(np.arange(rows, dtype=float), runs)
    w = ((t >= 20) & (t < 40)).astype(float)
    levels = rng.normal(0.0, 1.0, runs)[groups]
    x = levels if run_constant else levels + rng.normal(0.0, 1.0, groups.size)
    z = rng.normal(0.0, 1.0, runs)[groups] + rng.normal(0.0, 1.0, groups.size)
    y = scale * x * w + rng.normal(0.0, 0.3, groups.size)
    return pd.DataFrame({"run": groups, "x": x, "z": z}), y, w, groups, groups != 0


def test_a_column_that_scales_the_profile_is_told_from_one_that_does_not(oracle):
    table, y, w, groups, real = _record(runs=6, rows=100, seed=3, scale=1.0)
    base = np.ones((y.size, 1))
    rng = np.random.default_rng(0)
    assert oracle.stretch_p(y, base, table.x.to_numpy(), w, groups, real, rng) <= 1 / (1 + oracle.DRAWS)
    assert oracle.stretch_p(y, base, table.z.to_numpy(), w, groups, real, rng) > 0.05


def test_a_run_constant_column_over_three_runs_cannot_go_below_one_in_six(oracle):
    """Every ordering of three run levels is refitted: the observed one is the best of 3! = 6."""
    table, y, w, groups, real = _record(runs=3, rows=100, seed=5, scale=5.0, run_constant=True)
    p = oracle.stretch_p(y, np.ones((y.size, 1)), table.x.to_numpy(), w, groups, real, np.random.default_rng(0))
    assert p == pytest.approx(1 / math.factorial(3))


def test_a_surrogate_keeps_each_run_s_deviations_and_takes_another_run_s_mean(oracle):
    groups = np.repeat([0, 1, 2], 4)
    x = np.array([1.0, 2, 3, 6, 10, 10, 10, 10, -1, 0, 1, 0])
    out = oracle.surrogate(x, groups, np.array([2, 0, 1]), np.array([1, 0, 2]))
    np.testing.assert_allclose(out[:4], np.array([6.0, 1, 2, 3]) - 3.0 + 0.0)  # run 0: rolled by one, run 2's mean
    np.testing.assert_allclose(out[4:8], 3.0)  # run 1: constant, run 0's mean
    np.testing.assert_allclose(out[8:], np.array([1.0, 0, -1, 0]) + 10.0)  # run 2: rolled by two, run 1's mean


def test_the_told_test_adjusts_by_benjamini_hochberg_and_names_the_best_significant_column(oracle):
    """q against the step-up rule written out here, q_(i) = min over j ≥ i of m p_(j) / j; the column named is the
    one with the smallest refit RMSE among those with q below the level (None when none is)."""
    table, y, w, groups, real = _record(runs=5, rows=60, seed=11, scale=0.4)
    table = table.assign(x2=table.x + np.random.default_rng(2).normal(0.0, 0.5, len(table)))
    base = np.ones((y.size, 1))
    tests = oracle.told_test(table, y, base, w, ("z", "x", "x2"), "run", real, 7)
    rng = np.random.default_rng(7)
    p = np.array([oracle.stretch_p(y, base, table[c].to_numpy(), w, groups, real, rng) for c in ("z", "x", "x2")])
    np.testing.assert_allclose(tests.p, p)
    order = np.argsort(p)
    m = p.size
    q_sorted = np.minimum.accumulate((m * p[order] / np.arange(1, m + 1))[::-1])[::-1]
    q = np.empty(m)
    q[order] = np.minimum(q_sorted, 1.0)
    np.testing.assert_allclose(tests.q, q)
    assert oracle.told_verdict(tests) == "x"  # x2 is x read with noise: significant too, but transfers worse
    assert tests.rmse["x"] < tests.rmse["x2"] and tests.q["x2"] < oracle.FDR
    assert oracle.told_verdict(tests.assign(q=1.0)) is None


def test_exact_orderings_count_ties_with_the_observed_one(oracle):
    """Two runs sharing a level: the orderings that swap them give the observed fit again (p = 2/3! here)."""
    groups = np.repeat(np.arange(3), 50)
    t = np.tile(np.arange(50, dtype=float), 3)
    w = (t < 20).astype(float)
    x = np.array([0.0, 1.0, 1.0])[groups]
    y = 2.0 * x * w + np.random.default_rng(1).normal(0.0, 0.1, groups.size)
    p = oracle.stretch_p(y, np.ones((y.size, 1)), x, w, groups, groups != 0, np.random.default_rng(0))
    assert p == pytest.approx(2 / math.factorial(3))
