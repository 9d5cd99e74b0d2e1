"""Tests of the linear-axis error simulator and its nine-line measurement.

The reference problem is the S2 set-up: an X axis of 550 mm travel measured at 11 positions,
default error sizes (:class:`AxisConfig`), three measuring lines at
P1 = (0, 0, 200), P2 = (100, 0, 0), P3 = (-100, 200, 0) mm.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from svrqp.exceptions import ProblemError
from svrqp.formulations import nine_line
from svrqp.machine.geometry import (
    COMPONENTS,
    EFFECTS,
    URAD_PER_ARCSEC,
    AxisConfig,
    MeasuringLine,
    effect_components,
    measure_nine_line,
    simulate_axis,
    smooth_shape,
    true_components,
)

S2_AXIS = AxisConfig()
NOISE_FREE = replace(S2_AXIS, measurement_noise=0.0)


def test_identification_recovers_true_components_from_noise_free_readings():
    truth = true_components(NOISE_FREE)
    for method, identify in (("improved", nine_line.identify_improved),
                             ("original", nine_line.identify_original)):
        estimate = identify(measure_nine_line(NOISE_FREE, method))
        np.testing.assert_allclose(estimate["x_mm"], truth["x_mm"])
        np.testing.assert_allclose(estimate[list(COMPONENTS)], truth[list(COMPONENTS)],
                                   rtol=0, atol=1e-10, err_msg=method)


def test_readings_follow_the_small_angle_kinematics_by_hand():
    config = replace(NOISE_FREE, positions_mm=(275.0,))
    d_x, d_y, d_z, t_x, t_y, t_z = true_components(config)[list(COMPONENTS)].to_numpy()[0]
    table = measure_nine_line(config)
    for line, row in zip(config.lines, table.itertuples(), strict=True):
        assert row.dx_um == pytest.approx(d_x - line.y_off_mm * t_z / 1e3 + line.z_off_mm * t_y / 1e3)
        assert row.dy_um == pytest.approx(d_y + line.x_off_mm * t_z / 1e3 - line.z_off_mm * t_x / 1e3)
        assert row.dz_um == pytest.approx(d_z - line.x_off_mm * t_y / 1e3 + line.y_off_mm * t_x / 1e3)


def test_measurement_table_format_and_measured_sets():
    original = measure_nine_line(S2_AXIS, "original", seed=3)
    improved = measure_nine_line(S2_AXIS, "improved", seed=3)
    assert list(original.columns) == ["x_mm", "line", "x_off_mm", "y_off_mm", "z_off_mm",
                                      "dx_um", "dy_um", "dz_um"]
    assert len(original) == 33 and sorted(set(original["line"])) == [1, 2, 3]
    measured = original.groupby("line")[["dx_um", "dy_um", "dz_um"]].apply(lambda g: g.notna().all())
    np.testing.assert_array_equal(measured.to_numpy(),
                                  [[True, True, True], [True, True, False], [True, False, False]])
    assert improved[["dx_um", "dy_um", "dz_um"]].notna().all().all()
    # the two sets of one seed share the readings they have in common
    common = original[["dx_um", "dy_um", "dz_um"]].notna().to_numpy()
    np.testing.assert_array_equal(original[["dx_um", "dy_um", "dz_um"]].to_numpy()[common],
                                  improved[["dx_um", "dy_um", "dz_um"]].to_numpy()[common])


def test_reading_noise_has_configured_size():
    config = replace(S2_AXIS, positions_mm=tuple(np.linspace(0, 550, 400)), laser_noise_um=0.2)
    noisy = measure_nine_line(config, seed=11)[["dx_um", "dy_um", "dz_um"]].to_numpy()
    clean = measure_nine_line(replace(config, measurement_noise=0.0))[["dx_um", "dy_um", "dz_um"]]
    assert np.std(noisy - clean.to_numpy()) == pytest.approx(0.2, rel=0.05)


def test_error_sizes_are_realistic():
    config = replace(S2_AXIS, load_deflection=0.0, scale_thermal=0.0, periodic=0.0,
                     positions_mm=tuple(np.linspace(0, 550, 2001)))
    comp = true_components(config)
    peak_to_valley = comp[list(COMPONENTS)].max() - comp[list(COMPONENTS)].min()
    assert peak_to_valley["delta_y_um"] == pytest.approx(config.straightness_y_um, rel=1e-3)
    assert peak_to_valley["delta_z_um"] == pytest.approx(config.straightness_z_um, rel=1e-3)
    assert peak_to_valley["theta_x_urad"] / URAD_PER_ARCSEC == pytest.approx(config.roll_arcsec, rel=1e-3)
    assert peak_to_valley["theta_y_urad"] / URAD_PER_ARCSEC == pytest.approx(config.pitch_arcsec, rel=1e-3)
    np.testing.assert_allclose(comp.iloc[0, 1:], 0.0, atol=1e-12)  # errors counted from x = 0
    slope_um_per_m = comp["delta_x_um"].iloc[-1] / 0.55
    assert 5 <= slope_um_per_m <= 30 + config.positioning_shape_um / 0.55


def test_shape_is_zero_at_start_with_unit_peak_to_valley():
    u = np.linspace(0, 1, 1001)
    for seed in range(5):
        p = smooth_shape(u, seed)
        assert p[0] == 0.0
        assert np.ptp(p) == pytest.approx(1.0)


def test_scale_thermal_expansion_is_alpha_delta_t_x():
    warm = true_components(replace(S2_AXIS, axis_temperature_C=25.0))
    cold = true_components(replace(S2_AXIS, axis_temperature_C=20.0))
    expected = 1e3 * 11.5e-6 * 5.0 * warm["x_mm"]
    np.testing.assert_allclose(warm["delta_x_um"] - cold["delta_x_um"], expected, atol=1e-12)


def test_load_deflection_sags_by_mg_over_k_at_mid_travel():
    config = replace(S2_AXIS, positions_mm=(275.0,))
    load = effect_components(config, np.array([275.0]))["load_deflection"]
    assert load[0, 2] == pytest.approx(-300 * 9.80665 / 1000.0)
    assert load[0, 4] == pytest.approx(0.0, abs=1e-9)  # flat at the bottom of the sag


@pytest.mark.parametrize("effect", EFFECTS)
def test_turning_an_effect_off_removes_exactly_its_contribution(effect):
    on = simulate_axis(S2_AXIS, seed=5)
    off = simulate_axis(replace(S2_AXIS, **{effect: 0.0}), seed=5)
    column = f"effect_{effect}_um"
    np.testing.assert_array_equal(off[column], 0.0)
    np.testing.assert_allclose(off["error_um"], on["error_um"] - on[column], rtol=0, atol=1e-12)
    comp_on = true_components(S2_AXIS)[list(COMPONENTS)].to_numpy()
    comp_off = true_components(replace(S2_AXIS, **{effect: 0.0}))[list(COMPONENTS)].to_numpy()
    part = effect_components(S2_AXIS, np.asarray(S2_AXIS.positions_mm))[effect]
    assert np.abs(part).max() > 0.1  # every effect is there when on
    np.testing.assert_allclose(comp_off, comp_on - part, rtol=0, atol=1e-12)


def test_axis_error_is_sum_of_effects_plus_noise():
    df = simulate_axis(S2_AXIS, seed=1)
    effects = df[[f"effect_{e}_um" for e in EFFECTS]].sum(axis=1)
    np.testing.assert_allclose(df["error_um"], effects + df["noise_um"], atol=1e-12)
    np.testing.assert_array_equal(df["effect_roll_um"], 0.0)  # roll has no Abbe arm in X


def test_invalid_axis_configs_are_rejected():
    with pytest.raises(ProblemError, match="pitch"):
        AxisConfig(pitch=-1.0)
    with pytest.raises(ProblemError, match="positions_mm"):
        AxisConfig(positions_mm=(0.0, 600.0))
    with pytest.raises(ProblemError, match="exactly 3 lines"):
        AxisConfig(lines=(MeasuringLine(0, 0, 0),))
    with pytest.raises(ProblemError, match="method"):
        measure_nine_line(S2_AXIS, "fancy")
