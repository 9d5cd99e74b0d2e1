"""Blocked cross-validation of discrepancy models and the resampling helpers (svrqp.gap.data.discrepancy, .blocks).

The fast Gram-matrix scorer is checked against an independent reference: an explicit least-squares
fit (numpy.linalg.lstsq) on each fold's training rows, scored on its test rows.
"""

import numpy as np
import pytest

from svrqp.gap.data.discrepancy import CrossValidatedDiscrepancy
from svrqp.gap.data.runs import (
    block_bootstrap,
    blocked_folds,
    lag1_autocorrelation,
    rotated_rows,
    shift_offsets,
)

N = 600
GROUPS_FEW = np.repeat([0, 1], 300)  # two runs: interleaved blocks
GROUPS_MANY = np.repeat(np.arange(6), 100)  # six runs: whole runs held out


def _problem(seed=0):
    """Residual r = 0.8 z + base terms + noise; base = intercept + two regressors."""
    rng = np.random.default_rng(seed)
    B = np.column_stack([np.ones(N), rng.normal(size=(N, 2))])
    Z = rng.normal(size=(N, 3, 4))
    partner = rng.normal(size=(N, 3))
    r = B @ [0.5, 1.0, -2.0] + 0.8 * Z[:, 1, 2] + 0.3 * partner[:, 1] + rng.normal(scale=0.5, size=N)
    return r, B, Z, partner


def _reference_sse(r, B, columns, folds):
    sse = 0.0
    for test in folds:
        train = np.setdiff1d(np.arange(N), test)
        D = np.column_stack([B, columns])
        coef = np.linalg.lstsq(D[train], r[train], rcond=None)[0]
        sse += np.sum((r[test] - D[test] @ coef) ** 2)
    return sse


@pytest.mark.parametrize("groups", [GROUPS_FEW, GROUPS_MANY], ids=["few-groups", "many-groups"])
def test_sse_equals_fold_by_fold_least_squares(groups):
    r, B, Z, partner = _problem()
    folds = blocked_folds(groups)
    cv = CrossValidatedDiscrepancy(r, B, folds)
    assert cv.sse_base == pytest.approx(_reference_sse(r, B, np.zeros((N, 0)), folds), rel=1e-9)
    single, paired = cv.sse(Z), cv.sse(Z, partner)
    for j in range(3):
        for t in range(4):
            assert single[j, t] == pytest.approx(_reference_sse(r, B, Z[:, j, t], folds), rel=1e-7)
            both = np.column_stack([partner[:, j], Z[:, j, t]])
            assert paired[j, t] == pytest.approx(_reference_sse(r, B, both, folds), rel=1e-7)


def test_gain_is_largest_for_the_true_column():
    r, B, Z, _ = _problem()
    gains = CrossValidatedDiscrepancy(r, B, blocked_folds(GROUPS_MANY)).gain(Z)
    assert np.unravel_index(np.argmax(gains), gains.shape) == (1, 2)


def test_collinear_column_gives_no_gain():
    r, B, _, _ = _problem()
    cv = CrossValidatedDiscrepancy(r, B, blocked_folds(GROUPS_MANY))
    gain = cv.gain((2 * B[:, 1])[:, None, None])  # already in the base
    assert abs(gain[0, 0]) < 1e-6


@pytest.mark.parametrize("groups", [GROUPS_FEW, GROUPS_MANY], ids=["few-groups", "many-groups"])
def test_blocked_folds_partition_the_rows(groups):
    folds = blocked_folds(groups)
    assert np.array_equal(np.sort(np.concatenate(folds)), np.arange(N))
    assert len(folds) == 5


def test_many_groups_are_held_out_whole():
    for test in blocked_folds(GROUPS_MANY):
        held = np.unique(GROUPS_MANY[test])
        assert all(np.isin(np.flatnonzero(GROUPS_MANY == g), test).all() for g in held)


def test_few_groups_use_contiguous_blocks_of_every_run():
    for test in blocked_folds(GROUPS_FEW):
        assert set(GROUPS_FEW[test]) == {0, 1}  # each fold sees both runs
        runs = np.split(test, np.flatnonzero(np.diff(test) > 1) + 1)
        assert min(len(run) for run in runs) >= 300 // 20  # blocks, not single rows


def test_shifts_rotate_each_group():
    index = rotated_rows(GROUPS_FEW, shift_offsets(GROUPS_FEW, 50, np.random.default_rng(0)))
    for row in index:
        for g in (0, 1):
            own = np.flatnonzero(GROUPS_FEW == g)
            shifted = row[own]
            assert set(shifted) == set(own)  # stays within its group
            offset = (shifted[0] - own[0]) % own.size
            assert 30 <= offset <= 270  # at least a tenth of the group away from identity
            np.testing.assert_array_equal(shifted, own[0] + (np.arange(own.size) + offset) % own.size)


def test_shifts_avoid_copies_and_negated_copies_of_a_periodic_candidate():
    # A sine with a 60-row period in each 300-row group: shifts near whole periods copy it,
    # shifts near half periods negate it; neither may be drawn.
    chiller = np.sin(2 * np.pi * np.arange(N) / 60.0)
    index = rotated_rows(GROUPS_FEW, shift_offsets(GROUPS_FEW, 200, np.random.default_rng(1), chiller))
    for row in index:
        for g in (0, 1):
            own = np.flatnonzero(GROUPS_FEW == g)
            assert abs(np.corrcoef(chiller[row[own]], chiller[own])[0, 1]) <= 0.5 + 1e-9


def test_block_bootstrap_stays_within_groups_and_keeps_blocks():
    index = block_bootstrap(GROUPS_FEW, 20, 25, np.random.default_rng(0))
    assert index.shape == (20, N)
    np.testing.assert_array_equal(GROUPS_FEW[index], np.broadcast_to(GROUPS_FEW, index.shape))
    steps = np.diff(index[:, :25], axis=1)
    assert np.all(steps == 1)  # the first block is contiguous


def test_lag1_autocorrelation_of_an_ar1_process():
    rng = np.random.default_rng(3)
    e = np.zeros(20000)
    for k in range(1, e.size):
        e[k] = 0.6 * e[k - 1] + rng.normal()
    assert lag1_autocorrelation(e, np.zeros(e.size, int)) == pytest.approx(0.6, abs=0.02)
