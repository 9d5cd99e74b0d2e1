"""Tests of ``svrqp simulate`` and ``svrqp plot``.

The TOML fixture ``withheld_ambient.toml`` is a short thermal run (2 h soak, 30 min at
3000 rpm, 20 min stopped) with the ambient effect withheld and two sensors.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from svrqp.cli import app, main
from svrqp.machine.cycles import CycleSegment
from svrqp.machine.thermal import Ambient, Sensor, ThermalConfig, simulate_thermal

runner = CliRunner()

WITHHELD_AMBIENT_TOML = """\
ambient_drift = 0.0
soak_h = 2.0
[[cycle]]
duration_min = 30
speed_rpm = 3000
axis_duty_pct = 20
[[cycle]]
duration_min = 20
[ambient]
daily_amplitude_C = 0.5
[[sensors]]
name = "T1"
weights = {spindle = 0.8, headstock = 0.2}
[[sensors]]
name = "ambient"
weights = {ambient = 1.0}
lag_min = 5.0
"""


@pytest.fixture
def withheld_ambient(tmp_path: Path) -> Path:
    path = tmp_path / "withheld_ambient.toml"
    path.write_text(WITHHELD_AMBIENT_TOML, encoding="utf-8")
    return path


def _invoke(*args: str):
    result = runner.invoke(app, list(args))
    assert result.exit_code == 0, result.output
    return result


def test_thermal_config_file_sets_the_simulator(withheld_ambient, tmp_path):
    out = tmp_path / "run.csv"
    result = _invoke("simulate", "thermal", "--config", str(withheld_ambient), "--out", str(out),
                     "--seed", "3")
    assert "51 rows" in result.output
    written = pd.read_csv(out)
    expected = simulate_thermal(ThermalConfig(
        ambient_drift=0.0, soak_h=2.0,
        cycle=(CycleSegment(30, 3000, 20), CycleSegment(20)),
        ambient=Ambient(daily_amplitude_C=0.5),
        sensors=(Sensor("T1", {"spindle": 0.8, "headstock": 0.2}),
                 Sensor("ambient", {"ambient": 1.0}, lag_min=5.0)),
    ), seed=3)
    pd.testing.assert_frame_equal(written, expected, check_exact=False, rtol=1e-12)
    np.testing.assert_array_equal(written["effect_ambient_drift_um"], 0.0)


@pytest.mark.parametrize("kind, order, target", [("axis", "x_mm", "error_um"),
                                                 ("gantry", "time_s", "deviation_um")])
def test_axis_and_gantry_write_the_contract_table(tmp_path, kind, order, target):
    out = tmp_path / f"{kind}.csv"
    _invoke("simulate", kind, "--out", str(out))
    table = pd.read_csv(out)
    assert table.columns[0] == order and target in table and "noise_um" in table
    effects = [c for c in table if c.startswith("effect_")]
    np.testing.assert_allclose(table[target], table[effects].sum(axis=1) + table["noise_um"],
                               atol=1e-9)


def test_axis_nine_line_readings(tmp_path):
    out = tmp_path / "readings.csv"
    _invoke("simulate", "axis", "--nine-line", "original", "--out", str(out), "--seed", "1")
    table = pd.read_csv(out)
    assert list(table.columns) == ["x_mm", "line", "x_off_mm", "y_off_mm", "z_off_mm",
                                   "dx_um", "dy_um", "dz_um"]
    assert table["dz_um"].notna().sum() == 11  # only line 1 measures dz in the original set


def test_existing_output_needs_force(tmp_path, capsys):
    out = tmp_path / "g.csv"
    out.write_text("keep me", encoding="utf-8")
    with pytest.raises(SystemExit) as stop:
        main(["simulate", "gantry", "--out", str(out)])
    assert stop.value.code == 2
    assert "--force" in capsys.readouterr().err
    assert out.read_text(encoding="utf-8") == "keep me"
    _invoke("simulate", "gantry", "--out", str(out), "--force")
    assert out.read_text(encoding="utf-8").startswith("time_s,")


@pytest.mark.parametrize("toml, message", [
    ("bogus = 1\n", "unknown key"),
    ("ripple = 'strong'\n", "expected a number"),
    ("ripple = -1.0\n", "ripple"),
])
def test_bad_config_is_one_error_line(tmp_path, capsys, toml, message):
    config = tmp_path / "bad.toml"
    config.write_text(toml, encoding="utf-8")
    with pytest.raises(SystemExit) as stop:
        main(["simulate", "gantry", "--config", str(config), "--out", str(tmp_path / "x.csv")])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_nine_line_only_for_axis(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "thermal", "--nine-line", "improved", "--out", str(tmp_path / "x.csv")])
    assert "axis simulator only" in capsys.readouterr().err


def test_plot_draws_temperatures_and_error(withheld_ambient, tmp_path):
    data = tmp_path / "run.csv"
    _invoke("simulate", "thermal", "--config", str(withheld_ambient), "--out", str(data))
    figure = tmp_path / "fig.png"
    _invoke("plot", str(data), "--out", str(figure))
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_figure_has_labelled_axes_per_batch(tmp_path):
    from svrqp import datasets
    from svrqp.cli.simulate import plot_table

    figure = plot_table(datasets.load("miao2013"), temperatures=["T7_C", "T9_C"])
    axes = figure.axes
    assert len(axes) == 6  # temperatures and error for x1, x2, x3
    assert axes[0].get_ylabel() == "temperature (°C)"
    assert axes[3].get_ylabel() == "error (μm)" and axes[3].get_xlabel() == "time (min)"
    assert [ax.get_title() for ax in axes[:3]] == ["batch = x1", "batch = x2", "batch = x3"]


def test_plot_needs_an_order_column(tmp_path, capsys):
    data = tmp_path / "flat.csv"
    pd.DataFrame({"a": [1.0, 2.0], "error_um": [0.0, 1.0]}).to_csv(data, index=False)
    with pytest.raises(SystemExit):
        main(["plot", str(data), "--out", str(tmp_path / "f.png")])
    assert "order column" in capsys.readouterr().err
