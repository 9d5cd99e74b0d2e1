"""The simulated fleet (svrqp.machine.fleet): its kinds, its withheld effects, its truth."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from support.cli_runs import run

from svrqp.exceptions import ProblemError
from svrqp.machine.fleet import FAULTY_SENSOR, FleetDesign, machine_record

DESIGN = FleetDesign(n=10, runs=4, train_runs=1, run_min=120.0, seed=5,
                     snr={"nut": 3.0, "headstock": 3.0})


def _within_var(values: pd.Series, runs: pd.Series) -> float:
    return float(np.var(values - values.groupby(runs).transform("mean")))


def test_the_kinds_follow_the_shares_and_the_seed():
    kinds = DESIGN.kinds()
    assert sorted(kinds) == sorted(["nut"] * 3 + ["headstock"] * 2 + ["faulty"] + ["none"] * 4)
    assert kinds == DESIGN.kinds()
    with pytest.raises(ProblemError, match="unknown kind"):
        FleetDesign(n=3, shares={"rust": 1.0})


@pytest.mark.parametrize("kind", ["nut", "headstock", "none"])
def test_a_withheld_effect_acts_on_the_real_runs_at_its_strength(kind):
    table, truth = machine_record(DESIGN, 0, kind)
    again, _ = machine_record(DESIGN, 0, kind)
    pd.testing.assert_frame_equal(table, again)  # same seed, same machine
    gap = table["error_um"] - table["prediction_um"]
    train = table["run"] < DESIGN.train_runs
    sigma = truth["noise_um"]
    assert np.std(gap[train]) == pytest.approx(sigma, rel=0.15)  # the model is right there
    excess = _within_var(gap[~train], table.loc[~train, "run"]) / sigma**2 - 1.0
    snr = DESIGN.snr[kind] if kind != "none" else 0.0
    assert excess == pytest.approx(snr**2, abs=0.25 * snr**2 + 0.15)


def test_a_faulty_sensor_breaks_on_the_real_runs_only():
    healthy, _ = machine_record(DESIGN, 1, "none")
    faulty, truth = machine_record(DESIGN, 1, "faulty")
    assert truth["truth"] is None and truth["effect"] is None
    train = faulty["run"] < DESIGN.train_runs
    change = faulty[FAULTY_SENSOR] - healthy[FAULTY_SENSOR]
    assert np.allclose(change[train], 0.0) and np.abs(change[~train]).max() >= 1.0
    pd.testing.assert_series_equal(faulty["error_um"], healthy["error_um"])


def test_svrqp_simulate_fleet_writes_records_manifest_and_truth(tmp_path):
    out = tmp_path / "fleet"
    assert run(["simulate", "thermal", "--fleet", "3", "--out", str(out), "--seed", "2"]) == 0
    manifest, truth = pd.read_csv(out / "manifest.csv"), pd.read_csv(out / "truth.csv")
    assert list(manifest["name"]) == list(truth["name"]) == ["m0", "m1", "m2"]
    assert all((out / path).is_file() for path in manifest["path"])
    assert set(manifest.columns) >= {"target", "train", "prediction", "candidates"}
    assert run(["simulate", "axis", "--fleet", "3", "--out", str(tmp_path / "x")]) == 2
