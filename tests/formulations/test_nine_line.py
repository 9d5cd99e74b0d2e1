"""Nine-line identification (S2 eqs. 1–6): exact recovery, noise behaviour, bad geometry."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from svrqp.exceptions import ProblemError, SingularSystemError
from svrqp.formulations.least_squares import IllConditionedWarning
from svrqp.formulations.nine_line import (
    COMPONENTS,
    EXAMPLE_OFFSETS_MM,
    IMPROVED_SET,
    ORIGINAL_SET,
    arcsec_to_urad,
    identify_improved,
    identify_original,
    nine_line_matrix,
    simulate_readings,
    urad_to_arcsec,
)


@pytest.fixture
def s2_x_axis_components() -> pd.DataFrame:
    """Six smooth error components of S2's X axis at its 11 positions over 0–550 mm:
    a few μm of positioning error and straightness, tens of μrad of roll, pitch and yaw."""
    x_mm = np.linspace(0.0, 550.0, 11)
    u = x_mm / 550.0
    return pd.DataFrame({
        "x_mm": x_mm,
        "delta_x_um": 6.0 * u - 2.0 * np.sin(3.0 * u),
        "delta_y_um": 1.5 * np.sin(5.0 * u),
        "delta_z_um": -2.0 * u**2 + 0.7,
        "theta_x_urad": 12.0 * np.cos(4.0 * u),
        "theta_y_urad": -20.0 * u + 5.0,
        "theta_z_urad": 8.0 * np.sin(2.0 * u) - 3.0,
    })


def _forward_by_hand(row: pd.Series, offset_mm: np.ndarray) -> tuple[float, float, float]:
    """S2 eq. (1)–(2) written out term by term (mm · μrad · 1e-3 = μm)."""
    x_k, y_k, z_k = offset_mm
    dx = row.delta_x_um - 1e-3 * y_k * row.theta_z_urad + 1e-3 * z_k * row.theta_y_urad
    dy = row.delta_y_um + 1e-3 * x_k * row.theta_z_urad - 1e-3 * z_k * row.theta_x_urad
    dz = row.delta_z_um - 1e-3 * x_k * row.theta_y_urad + 1e-3 * y_k * row.theta_x_urad
    return dx, dy, dz


def test_simulated_readings_follow_the_kinematic_equations(s2_x_axis_components):
    table = simulate_readings(s2_x_axis_components, EXAMPLE_OFFSETS_MM)
    assert list(table.columns) == ["x_mm", "line", "x_off_mm", "y_off_mm", "z_off_mm",
                                   "dx_um", "dy_um", "dz_um"]
    assert len(table) == 3 * len(s2_x_axis_components)
    for _, reading in table.iterrows():
        row = s2_x_axis_components.loc[s2_x_axis_components.x_mm == reading.x_mm].iloc[0]
        expected = _forward_by_hand(row, EXAMPLE_OFFSETS_MM[int(reading.line) - 1])
        np.testing.assert_allclose(reading[["dx_um", "dy_um", "dz_um"]].to_numpy(float),
                                   expected, rtol=1e-14, atol=1e-14)


def test_original_set_leaves_three_readings_unmeasured(s2_x_axis_components):
    table = simulate_readings(s2_x_axis_components, EXAMPLE_OFFSETS_MM, ORIGINAL_SET)
    measured_per_position = table[["dx_um", "dy_um", "dz_um"]].notna().to_numpy().sum()
    assert measured_per_position == 6 * len(s2_x_axis_components)
    assert table.loc[table.line == 3, ["dy_um", "dz_um"]].isna().all().all()
    assert table.loc[table.line == 2, "dz_um"].isna().all()


def test_matrix_rows_and_shapes():
    A = nine_line_matrix(EXAMPLE_OFFSETS_MM, ORIGINAL_SET)
    assert A.shape == (6, 6)
    assert nine_line_matrix(EXAMPLE_OFFSETS_MM, IMPROVED_SET).shape == (9, 6)
    # Δy on line 2 (x = 100, z = 0 mm): δy + 1e-3·100·θz
    np.testing.assert_array_equal(A[4], [0.0, 1.0, 0.0, 0.0, 0.0, 0.1])


@pytest.mark.parametrize("identify, measured", [(identify_original, ORIGINAL_SET),
                                                (identify_improved, IMPROVED_SET)])
def test_exact_recovery_from_noise_free_readings(s2_x_axis_components, identify, measured):
    table = simulate_readings(s2_x_axis_components, EXAMPLE_OFFSETS_MM, measured)
    result = identify(table)
    assert list(result.columns) == ["x_mm", *COMPONENTS]
    np.testing.assert_allclose(result.to_numpy(), s2_x_axis_components[list(result.columns)]
                               .to_numpy(), rtol=0.0, atol=1e-10)


def test_improved_method_beats_original_under_noise():
    """Monte Carlo: 2000 positions, identical true components, reading noise σ = 0.5 μm.
    The ratio of component error standard deviations must match the factors stated in the
    nine_line docstring (from the covariance formulas), each one above 1."""
    rng = np.random.default_rng(2718)
    trials = 2000
    truth = pd.DataFrame({"x_mm": np.arange(trials, dtype=float),
                          **{name: np.full(trials, 3.0) for name in COMPONENTS}})
    table = simulate_readings(truth, EXAMPLE_OFFSETS_MM)
    readings = ["dx_um", "dy_um", "dz_um"]
    table[readings] += 0.5 * rng.standard_normal((len(table), 3))
    error_original = identify_original(table)[list(COMPONENTS)].to_numpy() - 3.0
    error_improved = identify_improved(table)[list(COMPONENTS)].to_numpy() - 3.0
    ratio = error_original.std(axis=0) / error_improved.std(axis=0)
    stated = np.array([1.25, 1.86, 1.52, 1.66, 1.33, 1.45])
    np.testing.assert_allclose(ratio, stated, rtol=0.08)
    assert (ratio > 1.1).all()


def test_lines_sharing_z_make_the_original_method_singular(s2_x_axis_components):
    shared_z = np.array([[0.0, 0.0, 0.0], [100.0, 150.0, 0.0], [-100.0, 200.0, 120.0]])
    table = simulate_readings(s2_x_axis_components, shared_z, ORIGINAL_SET)
    with pytest.raises(SingularSystemError, match="lines 1 and 2 share z"):
        identify_original(table)
    # The improved method's nine readings still identify everything.
    improved = identify_improved(simulate_readings(s2_x_axis_components, shared_z))
    np.testing.assert_allclose(improved[list(COMPONENTS)].to_numpy(),
                               s2_x_axis_components[list(COMPONENTS)].to_numpy(), atol=1e-10)


def test_nearly_shared_z_warns(s2_x_axis_components):
    nearly_shared = np.array([[0.0, 0.0, 0.0], [100.0, 150.0, 1e-4], [-100.0, 200.0, 120.0]])
    table = simulate_readings(s2_x_axis_components, nearly_shared, ORIGINAL_SET)
    with pytest.warns(IllConditionedWarning, match="nearly degenerate"):
        identify_original(table)


def test_collinear_points_make_the_original_method_singular(s2_x_axis_components):
    collinear = np.array([[0.0, 0.0, 200.0], [0.0, 100.0, 100.0], [0.0, 200.0, 0.0]])
    table = simulate_readings(s2_x_axis_components, collinear, ORIGINAL_SET)
    with pytest.raises(SingularSystemError, match=r"collinear in the \(y, z\) plane"):
        identify_original(table)


def test_improved_method_needs_all_nine_readings(s2_x_axis_components):
    table = simulate_readings(s2_x_axis_components, EXAMPLE_OFFSETS_MM, ORIGINAL_SET)
    with pytest.raises(ProblemError, match=r"improved.*x_mm=0.0.*dy_um on line 3"):
        identify_improved(table)


def test_malformed_tables(s2_x_axis_components):
    table = simulate_readings(s2_x_axis_components, EXAMPLE_OFFSETS_MM)
    with pytest.raises(ProblemError, match=r"missing column\(s\) \['dz_um'\]"):
        identify_improved(table.drop(columns="dz_um"))
    with pytest.raises(ProblemError, match=r"line must be 1, 2 or 3, found \[4\]"):
        identify_improved(table.assign(line=table.line.replace(3, 4)))
    with pytest.raises(ProblemError, match="need exactly one row per line"):
        identify_improved(table.iloc[1:])
    nan_offset = table.copy()
    nan_offset.loc[0, "y_off_mm"] = np.nan
    with pytest.raises(ProblemError, match="offsets must not be NaN"):
        identify_original(nan_offset)
    with pytest.raises(ProblemError, match="table is empty"):
        identify_original(table.iloc[:0])


def test_angle_units():
    np.testing.assert_allclose(arcsec_to_urad(1.0), 4.84813681109536, rtol=1e-14)
    np.testing.assert_allclose(urad_to_arcsec(arcsec_to_urad(np.array([2.5, -7.0]))),
                               [2.5, -7.0], rtol=1e-14)
