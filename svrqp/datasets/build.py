"""Generate the embedded datasets from the simulators with fixed seeds.

Each dataset imitates the set-up of one source paper (see its data card,
``svrqp/datasets/data/<name>.md``); all are SIMULATED, not measured. Values are rounded to the
resolution of real instruments (0.001 °C, 0.001 μm), and the target is recomputed from the
rounded effect and noise columns so that ``target = sum(effect columns) + noise_um`` still
holds exactly (to floating-point addition).

Regenerate the shipped CSV files with ``python -m svrqp.datasets.build`` (``--check``
compares instead of writing). Generation is deterministic: the same code and seeds give the
same bytes.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from svrqp.machine.contour import EFFECTS as GANTRY_EFFECTS, GantryConfig, simulate_gantry
from svrqp.machine.cycles import CycleSegment
from svrqp.machine.geometry import AxisConfig, measure_nine_line, true_components
from svrqp.machine.thermal import (
    DEFAULT_SENSORS,
    EFFECTS,
    Ambient,
    MachineStructure,
    Sensor,
    ThermalConfig,
    simulate_thermal,
)

DATA_DIR = Path(__file__).resolve().parent / "data"
DECIMALS = 3  # 0.001 °C and 0.001 μm: the resolution of the instruments imitated


# ---------------------------------------------------------------- S0: Miao et al. 2013

MIAO_SENSORS = tuple(s for s in DEFAULT_SENSORS if s.name in {f"T{i}" for i in range(1, 10)})
MIAO_DURATION_MIN = 250.0
# (batch, day of year, daily amplitude °C, clock hour at t = 0, seed). Summer runs start at 07:00
# on days whose air swings by ±5.1 °C, so the air rises by 5.25 °C in 250 min and T7 by about
# 7.25 °C, the largest rises among S0's support vectors (Table 1); autumn starts at 09:00 (±3.5 °C).
MIAO_BATCHES = (("x1", 185.0, 5.1, 7.0, 1), ("x2", 205.0, 5.1, 7.5, 2),
                ("x3", 290.0, 3.5, 9.0, 3))
#: Expansion lengths at 0.6 of the default machine: S0's MLR (eq. 5) gives 3.77 μm per °C of T7,
#: the default structure about 6.3; at 0.6 the simulated error per degree is S0's.
MIAO_LENGTH_SCALE = 0.6
_DEFAULT_STRUCTURE = MachineStructure()
MIAO_STRUCTURE = replace(
    _DEFAULT_STRUCTURE,
    spindle_length_mm=MIAO_LENGTH_SCALE * _DEFAULT_STRUCTURE.spindle_length_mm,
    headstock_length_mm=MIAO_LENGTH_SCALE * _DEFAULT_STRUCTURE.headstock_length_mm,
    column_length_mm=MIAO_LENGTH_SCALE * _DEFAULT_STRUCTURE.column_length_mm,
)


#: The absolute variant's own runs (``miao2013``): summer afternoons with air steady within
#: ±0.8 °C, the default machine. They predate the calibration of ``miao2013_rise`` to S0's
#: Table 1 and are kept as they were: the extrapolation lesson and the gap diagnosis built on them.
MIAO_ABSOLUTE_BATCHES = (("x1", 185.0, 0.8, 12.0, 1), ("x2", 205.0, 0.8, 12.5, 2),
                         ("x3", 290.0, 3.5, 9.0, 3))


def miao2013_config(day_of_year: float, daily_amplitude_C: float, start_hour: float, *,
                    zero_at_start: bool = False,
                    structure: MachineStructure = MIAO_STRUCTURE) -> ThermalConfig:
    """S0 set-up: a vertical machining centre run at 4500 rpm, no axis motion.

    With ``zero_at_start=False`` the error is counted from the 20 °C reference state, as a
    probe zeroed on the machine soaked at 20 °C would read it, so the structure's temperature
    level (which follows the season) is part of the error (the ``miao2013`` variant). With
    ``zero_at_start=True`` the probe is zeroed at the start of each run, as in S0
    (``miao2013_rise``).
    """
    return ThermalConfig(
        cycle=(CycleSegment(MIAO_DURATION_MIN + 1.0, 4500.0, 0.0),),
        ambient=Ambient(day_of_year=day_of_year, daily_amplitude_C=daily_amplitude_C,
                        start_hour=start_hour),
        sensors=MIAO_SENSORS,
        structure=structure,
        zero_at_start=zero_at_start,
    )


def _miao_batches(zero_at_start: bool, batches: tuple = MIAO_BATCHES,
                  structure: MachineStructure = MIAO_STRUCTURE) -> list[tuple[str, pd.DataFrame]]:
    """Each batch's simulated run, 0–250 min (a batch's seed fixes its noise whatever the rest)."""
    runs = []
    for batch, day, amplitude, start, seed in batches:
        config = miao2013_config(day, amplitude, start, zero_at_start=zero_at_start,
                                 structure=structure)
        run = simulate_thermal(config, seed=seed)
        runs.append((batch, run[run["time_min"] <= MIAO_DURATION_MIN].reset_index(drop=True)))
    return runs


def _miao_table(runs: list[tuple[str, pd.DataFrame]], sensors: list[str]) -> pd.DataFrame:
    columns = ["time_min", "speed_rpm", *sensors, "error_um", *_effect_columns(EFFECTS), "noise_um"]
    batches = [_round(run[columns].round(DECIMALS), "error_um", EFFECTS).assign(batch=batch)
               for batch, run in runs]
    table = pd.concat(batches, ignore_index=True)
    return table[["batch", *table.columns[:-1]]]


def miao2013() -> pd.DataFrame:
    """Absolute temperatures, error from the 20 °C reference: the extrapolation variant of S0.

    Its runs are :data:`MIAO_ABSOLUTE_BATCHES` on the default machine, not the calibrated runs of
    :func:`miao2013_rise`.
    """
    runs = _miao_batches(zero_at_start=False, batches=MIAO_ABSOLUTE_BATCHES,
                         structure=_DEFAULT_STRUCTURE)
    return _miao_table(runs, [f"{s.name}_C" for s in MIAO_SENSORS])


def miao2013_rise() -> pd.DataFrame:
    """S0's set-up: temperature rises and the error from the start of each run (probe zeroed).

    A rise is the sensor's reading minus its first reading of the run (S0 Table 1's support
    vectors start near 0 °C), so the first row of every batch holds zeros.
    """
    runs = _miao_batches(zero_at_start=True)
    for _, run in runs:
        for sensor in MIAO_SENSORS:
            reading = run[f"{sensor.name}_C"].round(DECIMALS)
            run[f"{sensor.name}_rise_C"] = (reading - reading.iloc[0]).round(DECIMALS)
    return _miao_table(runs, [f"{s.name}_rise_C" for s in MIAO_SENSORS])


# ---------------------------------------------------------------- S1: Chen & Gong 2012

RADIAL_STRUCTURE = MachineStructure(
    spindle_length_mm=20.0, headstock_length_mm=250.0, column_length_mm=-60.0, nut_length_mm=250.0
)
CHEN_SENSORS = (
    Sensor("coolant", {"coolant": 1.0}, lag_min=0.5),
    Sensor("nut", {"nut": 0.9, "column": 0.1}, lag_min=1.0),
    Sensor("spindle", {"spindle": 0.8, "headstock": 0.2}, lag_min=1.0),
    Sensor("bed", {"column": 1.0}, lag_min=2.0),
)
CHEN_CYCLE = (
    CycleSegment(60, 3000, 40), CycleSegment(30, 0, 0), CycleSegment(90, 5000, 60),
    CycleSegment(45, 2000, 20), CycleSegment(60, 4000, 50), CycleSegment(30, 0, 0),
    CycleSegment(90, 6000, 30), CycleSegment(100, 3500, 50),
)
#: Interferometer noise, μm: S1's tuned model leaves Σ|r| = 25 μm on its 20 test samples, a mean
#: |r| of 1.25 μm; white noise of σ = 1.5 μm has a mean |r| of 1.2 μm, the floor no model passes.
CHEN_NOISE_UM = 1.5


def chen2012() -> pd.DataFrame:
    """100 samples every 5 min: coolant, X-nut,
    spindle-bearing and bed temperatures, radial error."""
    config = ThermalConfig(
        cycle=CHEN_CYCLE, sensors=CHEN_SENSORS, structure=RADIAL_STRUCTURE, sample_min=5.0,
        ambient=Ambient(day_of_year=120.0, daily_amplitude_C=1.5, start_hour=8.0),
        measurement_noise_um=CHEN_NOISE_UM,
    )
    run = simulate_thermal(config, seed=12).iloc[:100]
    columns = ["time_min", "speed_rpm", "axis_duty_pct", "coolant_C", "nut_C", "spindle_C", "bed_C"]
    columns = [*columns, "error_um", *_effect_columns(EFFECTS), "noise_um"]
    table = _round(run[columns].round(DECIMALS), "error_um", EFFECTS)
    test = np.random.default_rng(2012).choice(len(table), size=20, replace=False)
    table["split"] = np.where(np.isin(np.arange(len(table)), test), "test", "train")
    return table


# ---------------------------------------------------------------- S3: Yang et al.

YANG_SPEEDS_RPM = (1500.0, 2500.0, 3500.0, 2000.0, 3000.0)
YANG_MACHINING_MIN, YANG_HANDLING_MIN, YANG_WORKPIECES = 8.0, 2.0, 50


def yang_turning() -> pd.DataFrame:
    """50 workpieces turned one after another; temperatures and radial error after each cut."""
    cycle = []
    for k in range(YANG_WORKPIECES):
        cycle += [CycleSegment(YANG_MACHINING_MIN, YANG_SPEEDS_RPM[k % len(YANG_SPEEDS_RPM)], 60.0),
                  CycleSegment(YANG_HANDLING_MIN, 0.0, 0.0)]
    config = ThermalConfig(
        cycle=tuple(cycle), sensors=CHEN_SENSORS, structure=RADIAL_STRUCTURE,
        ambient=Ambient(day_of_year=100.0, daily_amplitude_C=4.0, start_hour=7.0),
        measurement_noise_um=1.0,
    )
    run = simulate_thermal(config, seed=33)
    period = YANG_MACHINING_MIN + YANG_HANDLING_MIN
    measured = np.isclose(np.mod(run["time_min"] - YANG_MACHINING_MIN, period), 0.0)
    run = run[measured].iloc[:YANG_WORKPIECES].reset_index(drop=True)
    columns = ["time_min", "coolant_C", "nut_C", "spindle_C", "bed_C"]
    columns = [*columns, "error_um", *_effect_columns(EFFECTS), "noise_um"]
    table = _round(run[columns].round(DECIMALS), "error_um", EFFECTS)
    table.insert(0, "workpiece", np.arange(1, len(table) + 1))
    return table


# ---------------------------------------------------------------- S2: Zhou et al.

#: Reading noise, μm: a 5th-order polynomial through the 11 identified δx values leaves, in
#: expectation over the noise, 0.28 σ² (improved method): σ = 0.5 μm gives S2's LSM MSE 0.072 μm².
ZHOU_NOISE_UM = 0.5
#: S2 measures at 20 °C after the machine and the interferometer reach thermal equilibrium, so
#: the scale is at its reference temperature (no scale expansion). No ball-screw periodic error:
#: S2's MSEs leave no room for one (see ``zhou_axis_x_periodic``).
ZHOU_AXIS = AxisConfig(axis_temperature_C=20.0, periodic=0.0, laser_noise_um=ZHOU_NOISE_UM)
#: The variant with a 1 μm, 16 mm-lead ball-screw periodic error, aliased at 55 mm spacing.
ZHOU_AXIS_PERIODIC = replace(ZHOU_AXIS, periodic=1.0)


def _nine_line(axis: AxisConfig) -> pd.DataFrame:
    table = measure_nine_line(axis, "improved", seed=2)
    return table.round({"dx_um": DECIMALS, "dy_um": DECIMALS, "dz_um": DECIMALS})


def zhou_axis_x() -> pd.DataFrame:
    """Improved nine-line readings of the 550 mm X axis at 11 positions (long format)."""
    return _nine_line(ZHOU_AXIS)


def zhou_axis_x_true() -> pd.DataFrame:
    """The true six error components of the simulated axis at the 11 positions."""
    return true_components(ZHOU_AXIS).round(6)


def zhou_axis_x_periodic() -> pd.DataFrame:
    """The same readings with a ball-screw periodic error on δx (the variant)."""
    return _nine_line(ZHOU_AXIS_PERIODIC)


def zhou_axis_x_periodic_true() -> pd.DataFrame:
    """The true six error components of the periodic variant."""
    return true_components(ZHOU_AXIS_PERIODIC).round(6)


# ---------------------------------------------------------------- S4: Lin et al. 2011

# (run, minutes the motors have run before the record, seed): the same interpolation repeated as
# the machine warms, so a model fitted on run 1 can be scored on runs it never saw.
LIN_RUNS = ((1, 30.0, 4), (2, 50.0, 5), (3, 70.0, 6))
#: Guideway straightness, μm peak-to-valley: at 18 μm the recorded straightness of the runs is
#: 16 μm, S4's deviation before compensation (the other effects partly cancel it).
LIN_STRAIGHTNESS_UM = 18.0


def lin_gantry() -> pd.DataFrame:
    """Three records of a 150 mm linear interpolation at 400 mm/min at 15 Hz, one per run."""
    runs = []
    for run_id, warm_min, seed in LIN_RUNS:
        run = simulate_gantry(GantryConfig(motor_warm_min=warm_min,
                                          straightness_um=LIN_STRAIGHTNESS_UM), seed=seed)
        table = run.round({"time_s": 4, "x_mm": 6, "y_mm": 6, "feed_mm_min": DECIMALS,
                           "accel_mm_s2": DECIMALS, "motor_C": DECIMALS})
        runs.append(_round(table, "deviation_um", GANTRY_EFFECTS).assign(run=run_id))
    table = pd.concat(runs, ignore_index=True)
    return table[["run", *table.columns[:-1]]]


# ---------------------------------------------------------------- registry and writing

BUILDERS: dict[str, Callable[[], pd.DataFrame]] = {
    "miao2013": miao2013,
    "miao2013_rise": miao2013_rise,
    "chen2012": chen2012,
    "zhou_axis_x": zhou_axis_x,
    "zhou_axis_x_true": zhou_axis_x_true,
    "zhou_axis_x_periodic": zhou_axis_x_periodic,
    "zhou_axis_x_periodic_true": zhou_axis_x_periodic_true,
    "yang_turning": yang_turning,
    "lin_gantry": lin_gantry,
}


def _effect_columns(effects: tuple[str, ...]) -> list[str]:
    return [f"effect_{name}_um" for name in effects]


def _round(table: pd.DataFrame, target: str, effects: tuple[str, ...]) -> pd.DataFrame:
    """Round the effects and noise to 0.001 μm, then rebuild ``target`` from the rounded parts."""
    parts = [*_effect_columns(effects), "noise_um"]
    table = table.assign(**{column: table[column].round(DECIMALS) for column in parts})
    return table.assign(**{target: table[parts].sum(axis=1).round(DECIMALS)})


def to_csv_text(table: pd.DataFrame) -> str:
    """The exact text shipped for a dataset (Unix newlines, shortest float repr)."""
    return table.to_csv(index=False, lineterminator="\n")


def csv_path(name: str) -> Path:
    """Where the shipped CSV of ``name`` lives."""
    return DATA_DIR / f"{name}.csv"


def main(argv: list[str] | None = None) -> int:
    """Write (or with ``--check`` compare) every dataset's CSV; returns an exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare with the shipped files")
    args = parser.parse_args(argv)
    stale = []
    for name, build in BUILDERS.items():
        text = to_csv_text(build())
        path = csv_path(name)
        if args.check:
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                stale.append(name)
        else:
            path.write_text(text, encoding="utf-8")
            print(f"wrote {path} ({len(text.encode()) / 1024:.1f} KiB)")
    if stale:
        print(f"datasets differ from their generators: {stale}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
