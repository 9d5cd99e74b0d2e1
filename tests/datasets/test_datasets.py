"""Tests of the embedded datasets (svrqp.datasets) and of the FL_THERMAL loader.

The embedded datasets are regenerated here from their generators and must match the shipped
files byte for byte; their documented columns, sizes and the stories their cards tell are
checked against the data.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression

from support.paths import FL_THERMAL
from svrqp import datasets
from svrqp.exceptions import ProblemError
from svrqp.formulations.least_squares import straightness
from svrqp.formulations.nine_line import COMPONENTS, identify_improved
from svrqp.machine.geometry import measure_nine_line
from svrqp.datasets import build as generators

NAMES = ("chen2012", "lin_gantry", "miao2013", "miao2013_rise", "yang_turning", "zhou_axis_x",
         "zhou_axis_x_periodic", "zhou_axis_x_periodic_true", "zhou_axis_x_true")
TARGETS = {"miao2013": "error_um", "miao2013_rise": "error_um", "chen2012": "error_um", "yang_turning": "error_um",
           "lin_gantry": "deviation_um"}


def test_names_are_the_documented_datasets():
    assert datasets.names() == NAMES


@pytest.mark.parametrize("name", NAMES)
def test_every_column_is_documented_in_the_card(name):
    table, text = datasets.load(name), datasets.card(name)
    documented = set(re.findall(r"`([A-Za-z0-9_]+)`", text))
    assert set(table.columns) <= documented, set(table.columns) - documented
    assert "SIMULATED, not measured" in text
    assert not table.isna().any().any()


@pytest.mark.parametrize("name", NAMES)
def test_dataset_regenerates_bit_identically(name):
    shipped = generators.csv_path(name).read_text(encoding="utf-8")
    assert generators.to_csv_text(generators.BUILDERS[name]()) == shipped


def test_shipped_data_stay_small():
    total = sum(generators.csv_path(name).stat().st_size for name in NAMES)
    assert total < 300 * 1024


def test_unknown_name_lists_the_valid_ones():
    with pytest.raises(ProblemError, match="valid names: chen2012, lin_gantry"):
        datasets.load("miao2014")
    with pytest.raises(ProblemError, match="unknown dataset"):
        datasets.card("nothing")


@pytest.mark.parametrize("name", sorted(TARGETS))
def test_target_is_sum_of_effect_columns_plus_noise(name):
    table = datasets.load(name)
    effects = [c for c in table.columns if c.startswith("effect_")]
    assert len(effects) == 5
    np.testing.assert_allclose(table[TARGETS[name]], table[effects].sum(axis=1) + table["noise_um"],
                               rtol=0, atol=1e-9)


# ---------------------------------------------------------------- miao2013 (S0)


@pytest.fixture(scope="module")
def miao():
    return datasets.load("miao2013")


def _mlr_residuals(miao: pd.DataFrame) -> dict[str, np.ndarray]:
    """Residuals of S0's MLR on T7 and T9 fitted on batch x1, per batch."""
    features = ["T7_C", "T9_C"]
    x1 = miao[miao["batch"] == "x1"]
    model = LinearRegression().fit(x1[features], x1["error_um"])
    return {batch: (group["error_um"] - model.predict(group[features])).to_numpy()
            for batch, group in miao.groupby("batch")}


def test_miao_batches_seasons_and_time_axis(miao):
    assert sorted(miao["batch"].unique()) == ["x1", "x2", "x3"]
    for batch, group in miao.groupby("batch"):
        np.testing.assert_array_equal(group["time_min"], np.arange(251.0))
    ambient = miao.groupby("batch")["T9_C"].mean()
    assert ambient["x1"] == pytest.approx(30, abs=1) and ambient["x2"] == pytest.approx(30, abs=1)
    assert ambient["x3"] == pytest.approx(24, abs=1.5)


def test_miao_mlr_fits_summer_but_fails_in_autumn(miao):
    residuals = _mlr_residuals(miao)
    rms = {batch: float(np.sqrt(np.mean(r**2))) for batch, r in residuals.items()}
    assert rms["x1"] < 1.5 and rms["x2"] < 1.5  # S0: 1.263, 1.295 μm
    assert 3.0 < rms["x3"] < 12.0  # S0: 8.467 μm — several μm
    start_up = np.abs(residuals["x1"][:11]).max()  # S0: up to 4 μm in the first 10 min
    assert start_up > 2 * rms["x1"]


def test_miao_autumn_failure_is_the_lagged_ambient_effect_carried_by_t8(miao):
    residuals = _mlr_residuals(miao)
    real = miao[miao["batch"] != "x1"]
    gap = np.concatenate([residuals["x2"], residuals["x3"]])

    def explained(column: str) -> float:
        x = real[[column]]
        fit = LinearRegression().fit(x, gap)
        return 1 - np.mean((gap - fit.predict(x)) ** 2) / np.var(gap)

    candidates = {f"T{i}_C": explained(f"T{i}_C") for i in range(1, 9)}
    assert max(candidates, key=candidates.get) == "T8_C"
    ambient = miao.groupby("batch")["effect_ambient_drift_um"].agg(np.ptp)
    assert ambient["x3"] > 5 * max(ambient["x1"], ambient["x2"])  # hardly excited in summer


# ---------------------------------------------------------------- miao2013_rise (S0's set-up)


@pytest.fixture(scope="module")
def miao_rise():
    return datasets.load("miao2013_rise")


def test_miao_rise_autumn_is_the_absolute_variants_run_as_rises_from_the_first_reading(miao, miao_rise):
    # The summer runs differ (miao2013_rise is calibrated to S0's Table 1); autumn's temperatures
    # are the same run, and every batch's seed fixes its probe noise.
    for batch, absolute in miao.groupby("batch"):
        rise = miao_rise[miao_rise["batch"] == batch]
        np.testing.assert_array_equal(rise["noise_um"], absolute["noise_um"])  # same seeds, same noise
        first = rise.iloc[0]
        assert first[[c for c in rise.columns if c.startswith("effect_")]].abs().max() == 0.0
        assert first["error_um"] == first["noise_um"]  # the probe is zeroed at the start
    autumn, autumn_rise = miao[miao["batch"] == "x3"], miao_rise[miao_rise["batch"] == "x3"]
    for i in range(1, 10):
        expected = autumn[f"T{i}_C"].to_numpy() - autumn[f"T{i}_C"].iloc[0]
        np.testing.assert_allclose(autumn_rise[f"T{i}_rise_C"], expected, rtol=0, atol=1.5e-3)
    summer, summer_rise = miao[miao["batch"] == "x1"], miao_rise[miao_rise["batch"] == "x1"]
    assert summer_rise["T9_rise_C"].max() > 5 * np.ptp(summer["T9_C"])  # the calibrated summer air rises


def test_miao_rise_ranges_are_those_of_s0_table_1(miao_rise):
    # S0's support vectors (fitted on summer x1) reach T7 = 7.25 °C and T9 = 5.25 °C of rise.
    for batch in ("x1", "x2"):
        summer = miao_rise[miao_rise["batch"] == batch]
        assert summer["T7_rise_C"].max() == pytest.approx(7.25, abs=0.25)
        assert summer["T9_rise_C"].max() == pytest.approx(5.25, abs=0.25)
    x1, x3 = (miao_rise[miao_rise["batch"] == b] for b in ("x1", "x3"))
    for column in ("T7_rise_C", "T9_rise_C"):  # autumn's rises lie inside summer's range
        assert x1[column].min() <= x3[column].min() and x3[column].max() <= x1[column].max()


def test_miao_rise_error_per_degree_is_s0s(miao_rise):
    # S0's MLR (eq. 5): 3.7674 μm per °C of T7 rise, −0.4237 per °C of T9 rise.
    x1 = miao_rise[miao_rise["batch"] == "x1"]
    model = LinearRegression().fit(x1[["T7_rise_C", "T9_rise_C"]], x1["error_um"])
    assert model.coef_[0] == pytest.approx(3.7674, rel=0.1)
    assert -1.0 < model.coef_[1] < 0.0


def test_miao_rise_mlr_degrades_in_autumn_as_the_card_says(miao_rise):
    features = ["T7_rise_C", "T9_rise_C"]
    x1 = miao_rise[miao_rise["batch"] == "x1"]
    model = LinearRegression().fit(x1[features], x1["error_um"])
    rms = {batch: float(np.sqrt(np.mean((group["error_um"] - model.predict(group[features])) ** 2)))
           for batch, group in miao_rise.groupby("batch")}
    card = datasets.card("miao2013_rise")
    for batch in ("x1", "x2", "x3"):
        assert f"{rms[batch]:.2f}" in card.split("## What the physics produces")[1].split("##")[0]


# ---------------------------------------------------------------- the others


def test_chen_has_100_samples_every_5_min_split_80_20():
    table = datasets.load("chen2012")
    assert len(table) == 100
    # σ = 1.5 μm: the mean |noise| (0.8 σ) is S1's mean test |residual| of the tuned model, 25/20 μm
    assert np.mean(np.abs(table["noise_um"])) == pytest.approx(25 / 20, rel=0.25)
    np.testing.assert_array_equal(np.diff(table["time_min"]), 5.0)
    assert table["split"].value_counts().to_dict() == {"train": 80, "test": 20}
    for column in ("coolant_C", "nut_C", "spindle_C", "bed_C"):
        assert column in table


def test_zhou_readings_identify_the_true_components_within_noise():
    readings, truth = datasets.load("zhou_axis_x"), datasets.load("zhou_axis_x_true")
    assert len(readings) == 33 and len(truth) == 11
    np.testing.assert_allclose(truth["x_mm"], np.linspace(0, 550, 11))
    estimate = identify_improved(readings)
    error = estimate[list(COMPONENTS)].to_numpy() - truth[list(COMPONENTS)].to_numpy()
    assert np.abs(error[:, :3]).max() < 1.5  # μm: 3σ of readings with σ = 0.5 μm
    assert np.abs(error[:, 3:]).max() < 15.0  # μrad: 3σ over lever arms of 100–300 mm


def test_zhou_default_has_no_periodic_error_and_the_variant_only_adds_it():
    default, variant = datasets.load("zhou_axis_x"), datasets.load("zhou_axis_x_periodic")
    truth, variant_truth = datasets.load("zhou_axis_x_true"), datasets.load("zhou_axis_x_periodic_true")
    for column in ("dy_um", "dz_um"):
        np.testing.assert_array_equal(default[column], variant[column])
    added = variant_truth["delta_x_um"] - truth["delta_x_um"]
    assert 0.5 < np.abs(added).max() <= 1.0 + 1e-6  # a 1 μm periodic error, sampled every 55 mm
    for component in COMPONENTS[1:]:
        np.testing.assert_array_equal(truth[component], variant_truth[component])


def test_zhou_noise_gives_s2s_polynomial_mse_in_expectation():
    # σ = 0.5 μm: a 5th-order polynomial through the 11 identified δx leaves S2's 0.072 μm² on
    # average over the noise; its fit to the noise-free δx leaves nothing.
    u = np.linspace(0, 1, 11)
    mse = []
    for seed in range(60):
        dx = identify_improved(measure_nine_line(generators.ZHOU_AXIS, "improved", seed=seed))["delta_x_um"]
        mse.append(np.mean((dx - np.polyval(np.polyfit(u, dx, 5), u)) ** 2))
    assert np.mean(mse) == pytest.approx(0.072, rel=0.2)


def test_yang_fifty_workpieces_and_a_drifting_static_model():
    table = datasets.load("yang_turning")
    np.testing.assert_array_equal(table["workpiece"], np.arange(1, 51))
    assert table["error_um"].max() > 35  # S3: raw error above 35 μm
    features = ["coolant_C", "nut_C", "spindle_C", "bed_C"]
    static = LinearRegression().fit(table[features][:15], table["error_um"][:15])
    later = table["error_um"][15:] - static.predict(table[features][15:])
    assert np.abs(later).max() > 8  # S3: static LS leaves about 12 μm


def test_lin_gantry_is_the_s4_stroke_at_15_hz_repeated():
    table = datasets.load("lin_gantry")
    assert sorted(table["run"].unique()) == [1, 2, 3]
    for _, run in table.groupby("run"):
        np.testing.assert_allclose(np.diff(run["time_s"]), 1 / 15.0, atol=1e-4)
        assert run["x_mm"].iloc[-1] == pytest.approx(150.0, abs=0.01)
        assert run["feed_mm_min"].max() == pytest.approx(400.0)
        moving = run[run["feed_mm_min"] > 0]
        recorded = straightness(moving["x_mm"].to_numpy(), 1e3 * moving["y_mm"].to_numpy()).straightness
        assert recorded == pytest.approx(16.0, abs=1.0)  # S4: 16 μm before compensation
    # The runs share the machine, not the noise: the same geometry, different laser noise.
    first, second = (table[table["run"] == k] for k in (1, 2))
    np.testing.assert_array_equal(first["effect_guideway_straightness_um"], second["effect_guideway_straightness_um"])
    assert not np.array_equal(first["noise_um"], second["noise_um"])


def test_lin_gantry_card_states_the_straightness_of_each_run():
    table = datasets.load("lin_gantry")
    ranges = []
    for _, run in table[table["feed_mm_min"] > 0].groupby("run"):
        ranges.append(straightness(run["x_mm"].to_numpy(), 1e3 * run["y_mm"].to_numpy()).straightness)
    assert ", ".join(f"{value:.2f}" for value in ranges[:-1]) + f" and {ranges[-1]:.2f} μm" in datasets.card("lin_gantry")


# ---------------------------------------------------------------- FL_THERMAL loader


def _write_fl_file(path: Path, speeds: list[float]) -> Path:
    header = ["時間(s) ", "spindle(RPM)", *(f"ch{i}(um)" for i in range(1, 6)),
              *(f"t{i}(°C)" for i in range(1, 17))]
    rows = [[15 * k, s, *np.full(5, 0.5), *np.full(16, 25.0)] for k, s in enumerate(speeds)]
    pd.DataFrame(rows, columns=header).to_csv(path, index=False)
    return path


def test_fl_loader_labels_run_and_stop_phases(tmp_path):
    path = _write_fl_file(tmp_path / "fl.csv", [0, 0, 1250, 1250, 0, 0, 2500, 2500, 0])
    table = datasets.load_fl_thermal(path)
    assert table["phase"].tolist() == ["stop_0", "stop_0", "run_1250", "run_1250", "stop_1250",
                                       "stop_1250", "run_2500", "run_2500", "stop_2500"]
    assert table["segment"].tolist() == [0, 0, 1, 1, 2, 2, 3, 3, 4]
    np.testing.assert_allclose(table["time_min"], np.arange(9) * 0.25)
    assert list(table.columns[:7]) == ["time_min", "speed_rpm", "ch1_um", "ch2_um", "ch3_um",
                                       "ch4_um", "ch5_um"]
    assert table.columns[-3] == "t16_C"


def test_fl_loader_rejects_other_files(tmp_path):
    path = tmp_path / "other.csv"
    pd.DataFrame({"a": [1.0]}).to_csv(path, index=False)
    with pytest.raises(ProblemError, match="missing column"):
        datasets.load_fl_thermal(path)
    with pytest.raises(FileNotFoundError):
        datasets.load_fl_thermal(tmp_path / "absent.csv")


def test_fl_thermal_ships_unchanged_with_its_licence_and_card():
    """The shipped CSV is byte for byte the file converted from the source workbook."""
    assert hashlib.sha256(FL_THERMAL.read_bytes()).hexdigest() == datasets.FL_THERMAL_SHA256
    assert datasets.FL_THERMAL_SHA256.startswith("4a29ddd6")
    assert datasets.fl_thermal_licence().startswith("MIT License") and "CAIVIAC" in datasets.fl_thermal_licence()
    card = datasets.fl_thermal_card()
    assert "MEASURED, not simulated" in card and datasets.FL_THERMAL_SHA256 in card


def test_fl_loader_reads_the_real_measurements():
    table = datasets.load_fl_thermal()
    pd.testing.assert_frame_equal(table, datasets.load_fl_thermal(FL_THERMAL))
    assert len(table) == 11115
    np.testing.assert_allclose(np.diff(table["time_min"]), 0.25)
    phases = table.groupby("segment")["phase"].first().tolist()
    assert phases[:9] == ["stop_0", "run_1250", "stop_1250", "run_2500", "stop_2500", "run_3750",
                          "stop_3750", "run_5000", "stop_5000"]
    assert phases[-5:] == ["run_500", "run_1500", "run_2500", "run_4500", "stop_4500"]
    assert table["segment"].nunique() == 16
    assert table[[f"t{i}_C" for i in range(1, 17)]].stack().between(15, 45).all()
