"""Run-level candidates (svrqp.gap.transfer.ranking): exact permutation tests over few runs, the thin-evidence
verdict, and the plain level next to the between-run block."""

import json

import numpy as np
import pytest
from support.gap_problems import AXIS_CANDIDATES, axis_passes

from svrqp.gap import GapQuestion, diagnose


ARGS = {"target": "error_um", "train": "run == 'p0'", "prediction": "prediction_um", "order": "x_mm", "group": "run"}


def _diagnose(effect: str, runs: int, seed: int, engine_seed: int = 0):
    return diagnose(axis_passes(effect, runs=runs, seed=seed), GapQuestion(candidates=AXIS_CANDIDATES, **ARGS),
                    seed=engine_seed)


@pytest.mark.parametrize("engine_seed", [0, 7])
def test_over_five_passes_the_run_level_p_value_is_exact_and_names_the_cause(engine_seed):
    """5! = 120 orderings, only the observed one fits: p = 1/120 whatever the random draws, q = 3/120."""
    report = _diagnose("scale", runs=5, seed=0, engine_seed=engine_seed)
    top = report.causes[0]
    assert top.column == "axis_C" and top.p_raw == pytest.approx(1 / 120, abs=1e-15)
    assert top.p_value == pytest.approx(3 / 120, abs=1e-15)  # Benjamini–Hochberg over three columns
    assert report.verdict.column == "axis_C" and report.verdict.untestable is None


def test_null_passes_over_five_runs_name_nothing():
    for seed in range(3):
        report = _diagnose("none", runs=5, seed=seed)
        assert report.verdict.column is None and report.verdict.untestable is None


def test_three_passes_in_all_say_the_evidence_is_too_thin():
    """3! = 6 orderings: no permutation test reaches p < 1/6, however well the reading transfers."""
    report = _diagnose("scale", runs=3, seed=0)
    assert report.causes[0].column == "axis_C" and report.causes[0].shrink > 0.9
    verdict = report.verdict
    assert verdict.column is None and verdict.untestable == "axis_C"
    assert "only 6 orderings" in verdict.reason and "p-value below 0.17" in verdict.reason
    assert "too thin to name it" in verdict.reason
    assert "axis_C, one level per run, transfers best" in report.summary and "too thin" in report.summary
    assert len(report.summary.split()) <= 60
    assert json.loads(json.dumps(report.to_dict()))["verdict"]["untestable"] == "axis_C"  # schema-validated


def test_a_null_over_three_passes_is_not_called_untestable():
    report = _diagnose("none", runs=3, seed=0)
    assert report.verdict.column is None and report.verdict.untestable is None


def test_an_offset_in_proportion_to_a_run_level_reading_is_refitted_as_its_plain_level():
    """Each pass is off by 0.8 μm/K times its axis temperature: the plain level (one column) is the cause,
    and its shrink equals an independent leave-one-pass-out refit of target − prediction on [1, axis_C]."""
    df = axis_passes("none", runs=5, seed=0)
    df["error_um"] += 0.8 * (df.groupby("run")["axis_C"].transform("mean") - 20.0)
    report = diagnose(df, GapQuestion(candidates=AXIS_CANDIDATES, **ARGS))
    top = report.causes[0]
    assert (top.column, top.transform, top.evidence) == ("axis_C", "level", "within runs")
    assert report.verdict.column == "axis_C"
    d = (df["error_um"] - df["prediction_um"]).to_numpy()
    D = np.column_stack([np.ones(d.size), df["axis_C"].to_numpy()])
    runs, real = df["run"].to_numpy(), (df["run"] != "p0").to_numpy()
    errors = np.concatenate([d[runs == run] - D[runs == run] @ np.linalg.lstsq(D[runs != run], d[runs != run],
                                                                               rcond=None)[0]
                             for run in np.unique(runs[real])])
    oracle = 1 - np.sqrt(np.mean(errors**2)) / np.sqrt(np.mean(d[real] ** 2))
    assert top.shrink == pytest.approx(oracle, abs=1e-9)
