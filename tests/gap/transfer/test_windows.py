"""The localised transform of the gap diagnosis (svrqp.gap.transfer.windows): an effect in one stretch of the order axis.

The reference refit is plain :func:`numpy.linalg.lstsq` on ``[1, 1_W, x 1_W]`` (``1_W`` the window's
indicator built here from the window bounds), left one run out over all rows and scored on the real
rows, each fit keeping the window with the smallest error on its own rows.
"""

import re

import numpy as np
import pandas as pd
import pytest
from support.benchmark_modules import load_benchmark

from svrqp.exceptions import ProblemError
from svrqp.gap import GapQuestion, diagnose
from svrqp.gap.transfer.surrogates import exchange_run_levels
from svrqp.gap.transfer import windows as windows_module
from svrqp.gap.transfer.windows import MIN_REGION_ROWS, collinear, threshold_dictionary, window_dictionary

PATCH_MM = (20.0, 34.0)
QUESTION = {"target": "error_um", "prediction": "prediction_um", "train": "run == 0",
            "candidates": ["room_C", "humidity_pct"], "order": "x_mm", "group": "run", "local": True}


def _passes(carried: bool, seed: int = 3, runs: int = 8) -> pd.DataFrame:
    """Laser passes along 0…100 mm, one per run: a guideway patch between 20 and 34 mm whose error grows with
    the room temperature (``carried``), or a patch of random size per pass that no column reads."""
    rng = np.random.default_rng(seed)
    x = np.arange(0.0, 101.0)
    tables = []
    for run in range(runs):
        room = 20.0 if run == 0 else rng.uniform(19.0, 24.0)
        size = 1.5 * (room - 20.0) if carried else rng.normal(0.0, 1.5)
        patch = size * ((x >= PATCH_MM[0]) & (x <= PATCH_MM[1]))
        prediction = 0.02 * x
        tables.append(pd.DataFrame({
            "x_mm": x, "run": run, "room_C": room + 0.01 * rng.standard_normal(x.size),
            "humidity_pct": rng.uniform(30, 60), "prediction_um": prediction,
            "error_um": prediction + patch + 0.3 * rng.standard_normal(x.size)}))
    return pd.concat(tables, ignore_index=True)


@pytest.fixture(scope="module")
def patch():
    df = _passes(carried=True)
    return df, diagnose(df, GapQuestion(**QUESTION))


def _iou(a: tuple[float, float], b: tuple[float, float], t: np.ndarray) -> float:
    inside_a, inside_b = (t >= a[0]) & (t <= a[1]), (t >= b[0]) & (t <= b[1])
    return float(np.sum(inside_a & inside_b) / np.sum(inside_a | inside_b))


def test_a_local_effect_is_named_with_its_region(patch):
    df, report = patch
    verdict = report.verdict
    assert verdict.column == "room_C" and verdict.transform == "local"
    assert verdict.region["column"] == "x_mm"
    assert _iou((verdict.region["low"], verdict.region["high"]), PATCH_MM, df["x_mm"].to_numpy()) >= 0.5
    first = report.where[0]
    assert (first.column, first.low, first.high) == ("x_mm", verdict.region["low"], verdict.region["high"])
    assert "between" in report.summary and "x_mm" in report.summary
    document = report.to_dict()  # schema-valid with the region
    assert document["verdict"]["region"] == verdict.region


def test_the_local_form_is_offered_only_when_asked():
    report = diagnose(_passes(carried=True), GapQuestion(**QUESTION | {"local": False}))
    assert report.verdict.region is None and all(c.transform != "local" for c in report.causes)
    assert report.to_dict()["settings"]["local"] is False


def _leave_one_run_out_rmse(designs: list[np.ndarray], y: np.ndarray, runs: np.ndarray) -> float:
    """Real-row RMSE of least squares left one run out, each fit keeping the design with the smallest error on its rows."""
    squared = []
    for run in np.unique(runs[runs > 0]):
        test = runs == run
        fits = [(np.linalg.lstsq(D[~test], y[~test], rcond=None)[0], D) for D in designs]
        theta, D = min(fits, key=lambda fit: np.sum((y[~test] - fit[1][~test] @ fit[0]) ** 2))
        squared.append((y[test] - D[test] @ theta) ** 2)
    return float(np.sqrt(np.mean(np.concatenate(squared))))


def _window_designs(df: pd.DataFrame, with_candidate: bool) -> list[np.ndarray]:
    """``[1, 1_W, x 1_W]`` (or ``[1, 1_W]``, the window alone) of every window of the dictionary."""
    t, runs, x = df["x_mm"].to_numpy(), df["run"].to_numpy(), df["room_C"].to_numpy()
    indicators = [((t >= a) & (t <= b)).astype(float) for a, b in window_dictionary(t, runs, runs)]
    return [np.column_stack([np.ones(t.size), w] + ([x * w] if with_candidate else [])) for w in indicators]


def test_local_shrink_equals_an_independent_leave_one_run_out_refit(patch):
    df, report = patch
    cause = next(c for c in report.causes if c.column == report.verdict.column)
    y, runs = (df["error_um"] - df["prediction_um"]).to_numpy(), df["run"].to_numpy()
    reference = _leave_one_run_out_rmse(_window_designs(df, True), y, runs)
    assert cause.rmse_after == pytest.approx(reference, rel=1e-9, abs=1e-12)
    assert cause.shrink == pytest.approx(1 - reference / cause.rmse_before, abs=1e-9)


def test_a_local_cause_is_judged_beyond_its_window_alone(patch):
    """``shrink_beyond_window`` = 1 − RMSE with candidate × window / RMSE with the window's indicator alone."""
    df, report = patch
    cause = next(c for c in report.causes if c.column == report.verdict.column)
    y, runs = (df["error_um"] - df["prediction_um"]).to_numpy(), df["run"].to_numpy()
    alone = _leave_one_run_out_rmse(_window_designs(df, False), y, runs)
    assert cause.shrink_beyond_window == pytest.approx(1 - cause.rmse_after / alone, abs=1e-9)
    assert cause.shrink_beyond_window > 0.2  # the patch grows with the room: the window alone leaves a third of it
    assert all(c.shrink_beyond_window is None for c in report.causes if c.transform != "local")


def test_a_local_surrogate_exchanges_the_run_levels_and_keeps_each_run_s_shape():
    rng = np.random.default_rng(5)
    groups = np.repeat(np.arange(4), [7, 9, 6, 8])
    x = rng.normal(size=groups.size) + 10.0 * groups
    means = lambda v: np.array([v[groups == g].mean() for g in range(4)])
    draws = np.random.default_rng(1)
    seen = []
    for _ in range(60):
        xs = exchange_run_levels(x, groups, draws.permutation(4))
        seen.append(np.argsort(np.argsort(means(xs))))  # which of the four levels each run holds
        assert np.allclose(np.sort(means(xs)), np.sort(means(x)))  # the same levels, in other runs
        for g in range(4):  # within each run only the level moved
            rows = groups == g
            assert np.allclose(xs[rows] - xs[rows].mean(), x[rows] - x[rows].mean())
    assert all(set(column) == {0, 1, 2, 3} for column in np.array(seen).T)  # every run gets every level


def test_a_local_disturbance_no_candidate_carries_gets_no_verdict():
    report = diagnose(_passes(carried=False), GapQuestion(**QUESTION))
    assert report.verdict.column is None and report.verdict.region is None


def test_windows_narrower_than_five_rows_are_not_tried():
    t = np.tile(np.arange(0.0, 60.0, 1.0), 2)  # a 5 % tile holds 3 rows per run; a 10 % tile 6
    units = np.repeat([0, 1], 60)
    windows = window_dictionary(t, units, units)
    inside = [np.sum((t[:60] >= a) & (t[:60] <= b)) for a, b in windows]
    assert len(windows) and min(inside) >= MIN_REGION_ROWS  # no 3-row (5 %) tile survives
    one_unit = window_dictionary(np.arange(0.0, 10.0), np.zeros(10, dtype=int), np.zeros(10, dtype=int))
    assert one_unit.shape == (0, 2)  # a window seen in one unit only cannot be refitted without it


def test_a_stretch_that_starts_mid_tile_is_covered(monkeypatch):
    """A quarter of every run from its middle (rows 50–74 of 0–99): the unshifted 10 % and 20 % tiles
    each hold at most half of it (best IoU 15/30, the tile of rows 60–79); the 20 % tile laid half a
    tile on holds rows 50–69, IoU 20/25 (counted here row by row)."""
    t = np.tile(np.arange(100.0), 3)
    runs = np.repeat([0, 1, 2], 100)
    truth = (t[:100] >= 50) & (t[:100] <= 74)

    def best_iou() -> float:
        found = [(t[:100] >= a) & (t[:100] <= b) for a, b in window_dictionary(t, runs, runs)]
        return max(np.sum(truth & f) / np.sum(truth | f) for f in found)

    assert best_iou() == pytest.approx(0.8)
    monkeypatch.setattr(windows_module, "SHIFTED_MIN_WIDTH", 1.0)  # no shifted tiles: the dictionary before
    assert best_iou() == pytest.approx(0.5)


def test_a_clock_that_runs_on_through_the_runs_offers_no_window():
    runs = np.repeat([0, 1, 2], 60)
    shared = window_dictionary(np.tile(np.arange(60.0), 3), runs, runs)
    on_one_clock = window_dictionary(np.arange(180.0), runs, runs)  # each run its own stretch of time
    assert len(shared) and on_one_clock.shape == (0, 2)  # even the tiles across a seam of two runs


def test_ties_in_the_order_axis_are_refused():
    df = _passes(carried=True, runs=3)
    df.loc[5, "x_mm"] = df.loc[4, "x_mm"]
    with pytest.raises(ProblemError, match="repeated value"):
        diagnose(df, GapQuestion(**QUESTION))


def test_the_report_shades_the_region_and_draws_the_profile(patch, tmp_path):
    _, report = patch
    text = report.to_markdown(tmp_path / "gap.md")
    assert "acting only between" in text
    assert (tmp_path / "gap_before_after.png").stat().st_size > 0
    html = report.to_html(tmp_path / "gap.html").read_text(encoding="utf-8")
    assert "acting only between" in html


def test_a_window_collinear_with_the_model_is_detected():
    t = np.arange(0.0, 100.0)
    A = np.column_stack([np.ones(t.size), np.sin(t / 7)])
    w = ((t >= 20) & (t <= 30)).astype(float)
    x = np.where(w > 0, 21.5, np.cos(t / 3))  # constant inside the window: x 1_W = 21.5 1_W
    assert collinear(A, np.column_stack([w, x * w]))
    assert not collinear(A, np.column_stack([w, np.cos(t / 3) * w]))
    assert collinear(A, np.column_stack([np.ones(t.size), np.cos(t / 3)]))  # a window holding every row


@pytest.mark.parametrize("shared", [True, False])
def test_the_real_data_checker_tiles_the_axis_as_the_engine_does(shared):
    """benchmarks/gap_real.py writes the tile dictionary from its definition; the windows must be the engine's."""
    checker = load_benchmark("gap_real")
    cycles = ["1250", "2500", "3750", "5000", "mixed"]
    rows = [100, 90, 100, 80, 70]
    t = np.concatenate([np.arange(n) + (0.0 if shared else 100.0 * k) for k, n in enumerate(rows)])
    table = pd.DataFrame({"cycle": np.repeat(cycles, rows), "time_min": t})
    groups = np.repeat(np.arange(len(cycles)), rows)
    units = np.where(table["cycle"] == "5000", 0, np.where(table["cycle"] == "mixed", 1, -1))  # train rows: one unit
    engine = [((t >= low) & (t <= high)).astype(float) for low, high in window_dictionary(t, units, groups)]
    mine = checker.windows(table)
    assert len(mine) == len(engine) == (40 if shared else 0)  # 28 before the half-shifted tiles
    assert all(np.array_equal(a, b) for a, b in zip(mine, engine))


SPEED_RPM = 6000.0


def _speed_runs(seed: int = 4, runs: int = 6) -> pd.DataFrame:
    """Runs of 120 min whose spindle speed steps between four levels: a sensor ``T1_C`` that adds an error only
    while the speed is at or above 6000 rpm, wherever in the run that is."""
    rng = np.random.default_rng(seed)
    t = np.arange(120.0)
    tables = []
    for run in range(runs):
        speed = np.repeat(rng.permutation([2000.0, 4000.0, 6000.0, 8000.0]), 30)
        sensor = 20.0 + 3.0 * np.sin(t / 17.0 + run) + rng.normal(0.0, 1.0) + (0.0 if run else -2.0)
        effect = 1.2 * (sensor - 20.0) * (speed >= SPEED_RPM) if run else 0.0
        tables.append(pd.DataFrame({
            "time_min": t, "run": run, "speed_rpm": speed, "T1_C": sensor, "humidity_pct": rng.uniform(30, 60, t.size),
            "prediction_um": 0.0, "error_um": effect + 0.3 * rng.standard_normal(t.size)}))
    return pd.concat(tables, ignore_index=True)


SPEED_QUESTION = {"target": "error_um", "prediction": "prediction_um", "train": "run == 0",
                  "candidates": ["T1_C", "humidity_pct"], "order": "time_min", "group": "run", "local": True,
                  "local_along": "speed_rpm"}


def test_an_effect_confined_along_another_column_is_named_with_its_region_there():
    df = _speed_runs()
    report = diagnose(df, GapQuestion(**SPEED_QUESTION))
    verdict = report.verdict
    assert verdict.column == "T1_C" and verdict.transform == "local"
    assert verdict.region["column"] == "speed_rpm"
    speed = df["speed_rpm"].to_numpy()
    assert _iou((verdict.region["low"], verdict.region["high"]), (SPEED_RPM, speed.max()), speed) >= 0.5
    assert report.where[0].column == "speed_rpm" and "speed_rpm" in report.summary
    assert report.to_dict()["settings"]["local_along"] == ["speed_rpm"]


def test_windows_along_a_column_are_the_rows_above_or_below_its_deciles():
    v = np.tile(np.repeat([1.0, 2.0, 3.0, 4.0], 10), 3)
    runs = np.repeat([0, 1, 2], 40)
    windows = threshold_dictionary(v, runs, runs)
    assert {tuple(w) for w in windows} == {(2.0, 4.0), (3.0, 4.0), (4.0, 4.0), (1.0, 1.0), (1.0, 2.0), (1.0, 3.0)}
    assert threshold_dictionary(np.full(120, 7.0), runs, runs).shape == (0, 2)  # a constant column: no window


@pytest.mark.parametrize(("change", "message"), [({"local": False}, "ask local=True"),
                                                 ({"local_along": "time_min"}, "order axis"),
                                                 ({"local_along": "spindle_rpm"}, "spindle_rpm")])
def test_bad_local_along_is_refused(change, message):
    with pytest.raises(ProblemError, match=message):
        diagnose(_speed_runs(runs=3), GapQuestion(**SPEED_QUESTION | change))


def test_a_local_effect_of_a_run_level_reading_over_three_runs_is_called_too_thin_to_test():
    """Three passes: the room temperature's three levels have 3! = 6 orderings, so its local form cannot reach
    Benjamini–Hochberg's first threshold and is not tested; the engine names nothing and says why, with the window."""
    df = _passes(carried=True, runs=3)
    report = diagnose(df, GapQuestion(**QUESTION))
    verdict = report.verdict
    assert verdict.column is None and verdict.untestable == "room_C"
    assert all(c.transform != "local" or c.column != "room_C" for c in report.causes)  # refitted, never ranked
    found = re.search(r"The room_C term acting only between (\S+) and (\S+) mm of x_mm, one level per run, transfers "
                      r"best \(\d+% beyond the refit, \d+% beyond the window alone\), but its 3 run levels have only 6 "
                      r"orderings", verdict.reason)
    assert found is not None, verdict.reason
    assert _iou((float(found[1]), float(found[2])), PATCH_MM, df["x_mm"].to_numpy()) >= 0.5
    assert report.to_dict()["verdict"]["untestable"] == "room_C"
    assert "room_C, one level per run, transfers best" in report.summary


def test_without_the_local_form_the_same_passes_call_the_level_too_thin():
    report = diagnose(_passes(carried=True, runs=3), GapQuestion(**QUESTION | {"local": False}))
    assert report.verdict.untestable == "room_C"
    assert "The level of room_C, one level per run" in report.verdict.reason and "term acting" not in report.verdict.reason


def _drifting_passes(carried: bool, seed: int, runs: int = 3) -> pd.DataFrame:
    """Passes whose room temperature sits at one level per pass (10 to 30 °C) but drifts within it by a
    1 °C swing, far beyond its 0.01 °C reading noise; the patch grows with the room temperature there
    (``carried``) or has a random size per pass that no column reads."""
    rng = np.random.default_rng(seed)
    x = np.arange(0.0, 101.0)
    tables = []
    for run in range(runs):
        level = 20.0 if run == 0 else rng.uniform(10.0, 30.0)
        room = level + np.sin(2 * np.pi * x / 100 + rng.uniform(0, 2 * np.pi)) + 0.01 * rng.standard_normal(x.size)
        size = 1.5 * (room - 20.0) if carried else rng.normal(0.0, 1.5)
        inside = (x >= PATCH_MM[0]) & (x <= PATCH_MM[1])
        tables.append(pd.DataFrame({
            "x_mm": x, "run": run, "room_C": room, "humidity_pct": rng.uniform(30, 60), "prediction_um": 0.02 * x,
            "error_um": 0.02 * x + size * inside + 0.3 * rng.standard_normal(x.size)}))
    return pd.concat(tables, ignore_index=True)


def test_a_run_level_reading_that_drifts_within_runs_is_tested_in_its_window_over_three_runs():
    """One level per pass by its share of variance, but its movement within a pass is far above its noise: its local
    form is rotated within runs and has its run levels exchanged (as its level is), so three passes can name it
    where the permutation of three levels alone could not (it was called too thin to test)."""
    df = _drifting_passes(carried=True, seed=1)
    verdict = diagnose(df, GapQuestion(**QUESTION)).verdict
    assert (verdict.column, verdict.transform, verdict.untestable) == ("room_C", "local", None)
    assert _iou((verdict.region["low"], verdict.region["high"]), PATCH_MM, df["x_mm"].to_numpy()) >= 0.5


def test_a_patch_no_column_carries_is_not_pinned_on_a_drifting_reading():
    report = diagnose(_drifting_passes(carried=False, seed=1), GapQuestion(**QUESTION))
    assert report.verdict.column is None
