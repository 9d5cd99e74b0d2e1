"""Tests of the 2X/Y gantry linear-interpolation simulator.

Reference problem: the S4 set-up (:class:`GantryConfig` defaults) — a line of 150 mm in X and
4 mm in Y at 400 mm/min, recorded at 15 Hz, with Kv_x = 30/s and Kv_y = 20/s.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from svrqp.exceptions import ProblemError
from svrqp.machine.contour import EFFECTS, GantryConfig, path_profile, simulate_gantry

S4 = GantryConfig()


@pytest.fixture(scope="module")
def s4_record():
    return simulate_gantry(S4, seed=3)


def test_record_columns_time_base_and_stroke(s4_record):
    df = s4_record
    for name in ("time_s", "x_mm", "y_mm", "deviation_um", "motor_C", "noise_um",
                 *(f"effect_{e}_um" for e in EFFECTS)):
        assert name in df.columns
    np.testing.assert_allclose(np.diff(df["time_s"]), 1 / 15.0)
    assert df["x_mm"].iloc[-1] == pytest.approx(150.0, abs=0.01)
    assert df["y_mm"].iloc[-1] == pytest.approx(4.0, abs=0.01)
    assert df["feed_mm_min"].max() == pytest.approx(400.0)
    # 150 mm at 400 mm/min takes 22.5 s, plus acceleration and the two 1 s dwells
    assert 24.0 < df["time_s"].iloc[-1] < 25.5


def test_deviation_is_normal_distance_of_measured_point_from_command_line(s4_record):
    phi = np.arctan2(4.0, 150.0)
    normal_um = 1e3 * (-np.sin(phi) * s4_record["x_mm"] + np.cos(phi) * s4_record["y_mm"])
    np.testing.assert_allclose(normal_um, s4_record["deviation_um"], atol=1e-9)


def test_deviation_is_sum_of_effects_plus_noise(s4_record):
    total = s4_record[[f"effect_{e}_um" for e in EFFECTS]].sum(axis=1) + s4_record["noise_um"]
    np.testing.assert_allclose(s4_record["deviation_um"], total, atol=1e-12)


def test_size_matches_the_paper(s4_record):
    assert 10 < np.ptp(s4_record["deviation_um"]) < 20  # S4: 16 μm before compensation
    assert np.ptp(s4_record["effect_ripple_um"]) == pytest.approx(2.0, abs=0.05)


@pytest.mark.parametrize("effect", EFFECTS)
def test_turning_an_effect_off_removes_exactly_its_contribution(s4_record, effect):
    off = simulate_gantry(replace(S4, **{effect: 0.0}), seed=3)
    column = f"effect_{effect}_um"
    assert np.abs(s4_record[column]).max() > 0.5
    np.testing.assert_array_equal(off[column], 0.0)
    np.testing.assert_allclose(off["deviation_um"], s4_record["deviation_um"] - s4_record[column],
                               atol=1e-12)


def test_servo_lag_mismatch_matches_closed_form_and_scales_with_feed():
    phi = np.arctan2(4.0, 150.0)
    for feed in (400.0, 800.0):
        df = simulate_gantry(replace(S4, feed_mm_min=feed, acceleration_mm_s2=200.0), seed=0)
        cruising = df[df["feed_mm_min"] == feed].iloc[15:]  # 1 s: past the loop transient
        v = feed / 60.0
        expected_um = 1e3 * v * np.sin(phi) * np.cos(phi) * (1 / 30.0 - 1 / 20.0)
        np.testing.assert_allclose(cruising["effect_servo_lag_um"], expected_um, rtol=1e-6)
    equal_gains = simulate_gantry(replace(S4, kv_y_per_s=30.0), seed=0)
    np.testing.assert_allclose(equal_gains["effect_servo_lag_um"], 0.0, atol=1e-9)


def test_sync_error_is_worst_while_accelerating(s4_record):
    sync = s4_record["effect_sync_error_um"].abs()
    accelerating = s4_record["accel_mm_s2"] != 0
    assert sync[accelerating].max() > 2.0
    cruising = (s4_record["feed_mm_min"] == 400.0) & (s4_record["time_s"] > 2.0)
    assert sync[cruising].max() < 1e-3


def test_ripple_frequency_is_feed_over_pole_pitch(s4_record):
    cruising = s4_record[(s4_record["feed_mm_min"] == 400.0)]
    ripple = cruising["effect_ripple_um"].to_numpy()
    spectrum = np.abs(np.fft.rfft(ripple - ripple.mean()))
    freqs = np.fft.rfftfreq(ripple.size, d=1 / 15.0)
    assert freqs[np.argmax(spectrum)] == pytest.approx(400.0 / 60.0 / 1.5, abs=0.05)


def test_trapezoidal_profile_reaches_the_end():
    t = np.linspace(0, 30, 3001)
    s, speed, accel = path_profile(S4, t)
    assert s[-1] == pytest.approx(np.hypot(150.0, 4.0))
    assert speed.max() == pytest.approx(400.0 / 60.0)
    assert np.all(np.diff(s) >= -1e-12)


def test_invalid_gantry_configs_are_rejected():
    with pytest.raises(ProblemError, match="ripple"):
        GantryConfig(ripple=-0.5)
    with pytest.raises(ProblemError, match="feed_mm_min"):
        GantryConfig(feed_mm_min=0.0)
