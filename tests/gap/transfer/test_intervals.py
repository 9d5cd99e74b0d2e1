"""No bootstrap interval over fewer than five held-out units (issue #33): the runs are said too few."""

import json

import jsonschema
import numpy as np
import pytest
from support.gap_problems import CANDIDATES, air_lag_problem

from svrqp.gap import GapQuestion, diagnose, load_schema
from svrqp.gap.contract import THIN_UNITS
from svrqp.gap.diagnose import diagnose
from svrqp.gap.question import GapQuestion
from svrqp.gap.transfer.linear import bootstrap_index, transfer_shrink


def _errors(n_units: int, rows: int = 20, seed: int = 0):
    rng = np.random.default_rng(seed)
    units = np.repeat(np.arange(n_units), rows)
    before = rng.normal(0.0, 2.0, units.size)
    return before, 0.9 * before, 0.5 * before + rng.normal(0.0, 0.1, units.size), units


@pytest.mark.parametrize("n_units", [2, 3, THIN_UNITS - 1])
def test_too_few_units_give_no_interval(n_units):
    before, refit, after, units = _errors(n_units)
    index = bootstrap_index(n_units, np.random.default_rng(1))
    numbers = transfer_shrink(before, refit, after, units, n_units, index)
    assert numbers.shrink_ci is None and numbers.shrink_beyond_refit_ci is None
    assert numbers.shrink == pytest.approx(1 - np.sqrt(np.mean(after**2) / np.mean(before**2)))


def test_enough_units_give_the_percentile_interval_of_resampled_units():
    n_units = THIN_UNITS
    before, refit, after, units = _errors(n_units)
    index = bootstrap_index(n_units, np.random.default_rng(1))
    numbers = transfer_shrink(before, refit, after, units, n_units, index)
    # independent: resample whole units and recompute the ratio of root sums of squares
    sums = [np.array([np.sum(e[units == u] ** 2) for u in range(n_units)]) for e in (before, after)]
    shrinks = [1 - np.sqrt(sums[1][i].sum() / sums[0][i].sum()) for i in index]
    assert numbers.shrink_ci == pytest.approx(tuple(np.percentile(shrinks, [2.5, 97.5])))


def test_a_diagnosis_over_few_runs_says_they_are_too_few_for_an_interval():
    table = air_lag_problem()
    real_runs = table.loc[table["run"] != "r0", "run"].nunique()
    assert real_runs < THIN_UNITS
    result = diagnose(table, GapQuestion(target="error_um", train="run == 'r0'", features=["spindle_C"],
                                         candidates=CANDIDATES, order="time_min", group="run"))
    assert result.verdict.column == "air_C"
    assert all(c.shrink_ci is None for c in result.causes) and result.verdict.shrink_ci is None
    assert "too few for an interval" in result.verdict.reason
    document = json.loads(result.to_json())
    jsonschema.validate(document, load_schema())
    assert document["transfer"]["thin"] is True and document["verdict"]["shrink_ci"] is None
