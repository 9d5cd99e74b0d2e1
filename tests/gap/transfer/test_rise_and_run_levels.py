"""Two kinds of evidence the diagnosis used to miss: heating since a run's start, and a run-level
driver over five to eight runs whose levels repeat.

The rise :math:`x - x(t_0)` is a transform of its own (one column, rotated within runs with its
seam lifted); a run-level candidate whose orderings cannot reach Benjamini–Hochberg's first
threshold is tested by the between-run t-test. Each verdict's shrink is checked against an
independent leave-one-run-out refit written out here with numpy.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from svrqp.gap import GapQuestion, diagnose
from svrqp.gap.data.transforms import rise
from svrqp.gap.transfer.between import permutation_floor

RUN_MIN = 180


def _lag(x: np.ndarray, tau: float) -> np.ndarray:
    alpha = 1 - np.exp(-1.0 / tau)
    return lfilter([alpha], [1, -(1 - alpha)], x, zi=[(1 - alpha) * x[0]])[0]


def heating_runs(effect: bool, runs: int = 5, seed: int = 0) -> pd.DataFrame:
    """Runs whose nut heats with the axis's duty from wherever the run starts.

    ``prediction_um`` models the spindle; the unmodelled effect, ``b (nut - nut(t0))``, builds up over
    each run but the first (the train run, with the axis idle). Decoys: the air (its level differs by run, slow drift within) and the coolant (the air
    through a lag plus a chiller cycle).
    """
    rng = np.random.default_rng(seed)
    t = np.arange(RUN_MIN, dtype=float)
    tables = []
    for run in range(runs):
        air = 18 + 8 * rng.random() + 0.01 * rng.normal(size=RUN_MIN).cumsum()
        # The train run r0 kept the axis idle: the model never saw the nut heat.
        duty = np.repeat(rng.choice([20.0, 50.0, 80.0], size=RUN_MIN // 60), 60) * (run > 0)
        nut = air + 2 * rng.random() + _lag(duty / 10, 40)
        spindle = air + _lag(np.full(RUN_MIN, 6.0), 20)
        prediction = 2.0 * spindle
        noise = lfilter([1.0], [1.0, -0.7], rng.normal(scale=0.2, size=RUN_MIN))
        contribution = 1.2 * (nut - nut[0]) if effect else np.zeros(RUN_MIN)
        tables.append(pd.DataFrame({
            "run": f"r{run}", "time_min": t, "prediction_um": prediction,
            "error_um": 2.0 * spindle + contribution + noise,
            "nut_C": nut + 0.02 * rng.normal(size=RUN_MIN), "air_C": air + 0.02 * rng.normal(size=RUN_MIN),
            "coolant_C": _lag(air, 15) + 0.5 * np.sin(2 * np.pi * t / 45) + 0.02 * rng.normal(size=RUN_MIN),
        }))
    return pd.concat(tables, ignore_index=True)


def loaded_passes(effect: bool, passes: int = 7, seed: int = 0) -> pd.DataFrame:
    """Laser passes at two table loads (100 and 400 kg, alternating), the first the train pass.

    The unmodelled deflection, ``0.01 μm/kg · load · (x / 550 mm)²``, is a profile along the pass that the
    load scales; the loads repeat, so the real passes' six levels have only 20 distinct orderings.
    """
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 550.0, 23)
    geometry = 0.01 * x + 1.5 * np.sin(2 * np.pi * x / 350.0)
    tables = []
    for k in range(passes):
        load = (100.0, 400.0)[k % 2]
        deflection = 0.01 * load * (x / 550.0) ** 2 if effect else np.zeros(x.size)
        tables.append(pd.DataFrame({
            "run": f"p{k}", "x_mm": x, "load_kg": load, "axis_C": 20 + 3 * rng.random() + 0.01 * rng.normal(size=x.size),
            "humidity_pct": 35 + 20 * rng.random(), "prediction_um": geometry,
            "error_um": geometry + deflection + 0.3 * rng.normal(size=x.size),
        }))
    return pd.concat(tables, ignore_index=True)


def independent_shrink_beyond_refit(table: pd.DataFrame, columns: np.ndarray, train_runs: list[str]) -> float:
    """Leave one run out over all runs, least squares of target − prediction on ``[1, columns]``, scored on
    the real runs: 1 − RMSE(with the columns) / RMSE(intercept only)."""
    d = (table["error_um"] - table["prediction_um"]).to_numpy()
    runs = table["run"].to_numpy()
    real = ~np.isin(runs, train_runs)

    def rmse(design: np.ndarray) -> float:
        errors = []
        for run in np.unique(runs[real]):
            out = runs == run
            coef = np.linalg.lstsq(design[~out], d[~out], rcond=None)[0]
            errors.append(d[out] - design[out] @ coef)
        return float(np.sqrt(np.mean(np.concatenate(errors) ** 2)))

    ones = np.ones((len(d), 1))
    return 1.0 - rmse(np.column_stack([ones, columns])) / rmse(ones)


def test_rise_is_the_change_since_each_runs_first_row():
    x = np.array([5.0, 6.0, 8.0, 1.0, 0.5, 3.0])
    groups = np.array([0, 0, 0, 1, 1, 1])
    np.testing.assert_array_equal(rise(x, np.arange(6.0), groups), [0.0, 1.0, 3.0, 0.0, -0.5, 2.0])


@pytest.mark.parametrize(("levels", "floor"), [
    (np.arange(5.0), 1 / 120),
    (np.array([1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 2.0, 2.0]), math.factorial(4) * math.factorial(5) / math.factorial(9)),
    (np.array([3.0, 3.0 + 1e-15, 7.0]), 2 / 6),  # equal to rounding: one level
])
def test_permutation_floor_counts_the_orderings_that_leave_the_levels_as_they_are(levels, floor):
    assert permutation_floor(levels) == pytest.approx(floor, rel=1e-12)


def test_heating_since_the_runs_start_is_named_with_the_shrink_of_an_independent_refit():
    table = heating_runs(effect=True)
    question = GapQuestion(target="error_um", train="run == 'r0'", prediction="prediction_um",
                           candidates=["nut_C", "air_C", "coolant_C"], order="time_min", group="run")
    report = diagnose(table, question, seed=0)
    assert (report.verdict.column, report.verdict.transform, report.verdict.tau) == ("nut_C", "rise", None)
    assert "rise of nut_C since each run's start" in report.summary
    nut_rise = (table["nut_C"] - table.groupby("run")["nut_C"].transform("first")).to_numpy()
    expected = independent_shrink_beyond_refit(table, nut_rise[:, None], ["r0"])
    assert report.verdict.shrink_beyond_refit == pytest.approx(expected, rel=1e-6)
    assert expected > 0.3


def test_no_rise_is_named_where_nothing_heats():
    table = heating_runs(effect=False, seed=1)
    question = GapQuestion(target="error_um", train="run == 'r0'", prediction="prediction_um",
                           candidates=["nut_C", "air_C", "coolant_C"], order="time_min", group="run")
    assert diagnose(table, question, seed=0).verdict.column is None


def test_a_load_at_two_levels_over_six_passes_is_named_by_the_t_test():
    table = loaded_passes(effect=True)
    question = GapQuestion(target="error_um", train="run == 'p0'", prediction="prediction_um",
                           candidates=["load_kg", "axis_C", "humidity_pct"], order="x_mm", group="run")
    report = diagnose(table, question, seed=0)
    assert report.verdict.column == "load_kg"
    top = next(c for c in report.causes if c.column == "load_kg")
    assert top.significant and "t-test" in top.note
    assert permutation_floor(np.array([100.0, 400.0] * 3)) == pytest.approx(1 / 20)  # no ordering could decide


def test_no_load_is_named_on_passes_that_do_not_deflect():
    table = loaded_passes(effect=False, seed=2)
    question = GapQuestion(target="error_um", train="run == 'p0'", prediction="prediction_um",
                           candidates=["load_kg", "axis_C", "humidity_pct"], order="x_mm", group="run")
    assert diagnose(table, question, seed=0).verdict.column is None
