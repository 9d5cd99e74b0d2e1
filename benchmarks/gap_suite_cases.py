"""Scenarios and cases of the gap validation suite (:mod:`gap_suite`, whose docstring describes them).

A :class:`Scenario` names what is simulated and withheld; :func:`case_for` simulates it into a
:class:`Case` (the table, the candidates and the truth). The grids (:data:`GRIDS`) and the scenario
lists (:func:`scenarios`, :func:`local_scenarios`, :func:`transfer_scenarios`) are here too.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from svrqp.machine import ThermalConfig, simulate_thermal
from svrqp.machine.contour import GantryConfig, simulate_gantry
from svrqp.machine.cycles import CycleSegment
from svrqp.machine.geometry import EFFECTS as AXIS_EFFECTS
from svrqp.machine.geometry import AxisConfig, simulate_axis
from svrqp.machine.thermal import EFFECTS as THERMAL_EFFECTS
from svrqp.machine.thermal import Ambient

RESULTS = Path(__file__).resolve().parent / "results"
#: Transforms :mod:`transfer_oracle` refits.
ORACLE_TRANSFORMS = ("level", "rate", "rise", "lag")
AR_PHI = 0.8
SUMMER_DAYS = (170.0, 230.0)
WINTER_DAYS = (0.0, 40.0)
TRUTH_SHARE_MIN, DECOY_SHARE_MAX = 0.1, 0.1

SENSORS = tuple(f"{s.name}_C" for s in ThermalConfig().sensors)
DRIVERS = ("speed_rpm", "axis_duty_pct")
# Input column of each thermal effect (None: not a column of the table).
DRIVER_OF = {"spindle_heating": "speed_rpm", "headstock_heating": "speed_rpm", "nut_heating": "axis_duty_pct",
             "coolant_chiller": None, "ambient_drift": None}
# Columns that read the driving input itself.
INPUT_SENSORS = {"ambient_drift": ("ambient_C", "T9_C")}

# Features mode: node sensors of the model; a withheld node sensor and its decoy pool.
NODE_SENSORS = ("T1_C", "T4_C", "bed_C", "nut_C", "coolant_C", "ambient_C")
DECOYS_FEATURES = {
    "T1_C": ("T5_C", "T9_C", "speed_rpm", "axis_duty_pct", "T8_C"),
    "T4_C": ("T9_C", "speed_rpm", "axis_duty_pct", "coolant_C", "nut_C"),
    "bed_C": ("T5_C", "T9_C", "speed_rpm", "axis_duty_pct", "T1_C"),
    "nut_C": ("T5_C", "T6_C", "T8_C", "T9_C", "speed_rpm"),
}
NODE_OF_SENSOR = {"T1_C": "spindle", "T4_C": "headstock", "bed_C": "column", "nut_C": "nut"}
NODE_LENGTH_MM = {"spindle": 200.0, "headstock": 250.0, "column": -350.0, "nut": 120.0}
EXPANSION_PER_K = 11.5e-6
NULL_FEATURES_POOL = ("speed_rpm", "axis_duty_pct", "cabinet_C", "humidity_pct")
"""Candidates of a features-mode null: the drivers and two readings of nothing the model's nodes feel (every
thermal sensor reads a model node, and a second reading of one is no decoy: DESIGN §4's nulls)."""
NULL_PREDICTION_POOL = ("T1_C", "T4_C", "nut_C", "coolant_C", "ambient_C", "bed_C", "speed_rpm", "axis_duty_pct")

ORDER = {"thermal": "time_min", "gantry": "time_s", "axis": "x_mm"}
"""Order axis of each family (the part of the family name before the slash)."""

AXIS_TRUTH = {"scale_thermal": ("axis_C",), "load_deflection": ("load_kg",)}
AXIS_UNMEASURED = ("positioning", "periodic")
AXIS_CANDIDATES = ("axis_C", "load_kg", "ambient_C", "humidity_pct")
AXIS_TRAVEL_MM = 550.0

GANTRY_TRUTH = {"servo_lag": ("feed_mm_min",), "sync_error": ("accel_mm_s2",), "motor_heating": ("motor_C",)}
GANTRY_UNMEASURED = ("ripple", "guideway_straightness")
GANTRY_CANDIDATES = ("feed_mm_min", "accel_mm_s2", "motor_C")
GANTRY_CANDIDATES_FOR = {"sync_error": ("accel_mm_s2", "motor_C")}

RUN_LEVEL_EFFECTS = ("motor_heating", "scale_thermal", "load_deflection", "zone", "patch", "load")
"""Effects whose driver holds one level per run by the simulator's own definition (the gantry motor's
temperature through a short pass, the axis temperature, table load and room through a laser pass, the
commanded acceleration of a pass)."""

MIN_RUN_LEVEL_RUNS = 6
"""Fewest runs of a scenario whose truth is run-level (DESIGN §4: six runs, the driver at two levels or more)."""


@dataclass(frozen=True)
class Scenario:
    """One scenario of the grid (see the module docstring)."""

    name: str
    family: str  # thermal/prediction, thermal/features, gantry/prediction, axis/prediction
    kind: str  # withheld, null, unmeasured
    effect: str | None  # withheld effect (thermal/features: the withheld node sensor)
    snr: float  # std of the identifiable part of the withheld effect / noise std
    runs: int
    run_min: float
    ar: bool
    seed: int
    n_decoys: int = 5
    model: str = "mlr"
    null_noise_um: float = 0.3  # noise std of null scenarios (no effect to scale it by)
    positions: int = 0  # measured positions per pass (axis family)
    continuous: bool = False  # one record without runs: the clock runs on and no --group is given
    window: tuple[float, float] | None = None  # local kinds: the effect's stretch, as fractions of the order axis
    shape: str = "indicator"  # local kinds: indicator, bump (half sine) or transient (decaying exponential)


class NoRightAnswer(ValueError):
    """The simulator drew a withheld scenario in which no offered column carries the effect on the real rows:
    it has no right answer, and the suite leaves it out of every target before the engine runs."""


@dataclass(frozen=True)
class Case:
    """A simulated scenario: the table, the candidates offered and the right answers."""

    table: pd.DataFrame
    candidates: tuple[str, ...]
    truth: tuple[str, ...]


# ----------------------------------------------------------------------------- data


def train_query(s: Scenario) -> str:
    """Train rows: the first run (the first two thermal runs when there are five or more)."""
    return "run < 2" if s.family.startswith("thermal") and s.runs >= 5 else "run < 1"


def _n_train(s: Scenario) -> int:
    return 2 if s.family.startswith("thermal") and s.runs >= 5 else 1


def _noise(n: int, sigma: float, ar: bool, rng: np.random.Generator, runs: np.ndarray) -> np.ndarray:
    """White or AR(1) noise of standard deviation ``sigma``, restarting per run."""
    white = rng.standard_normal(n)
    if not ar:
        return sigma * white
    out = np.empty(n)
    for run in np.unique(runs):
        rows = np.flatnonzero(runs == run)
        out[rows[0]] = white[rows[0]]
        for k in range(1, rows.size):
            out[rows[k]] = AR_PHI * out[rows[k - 1]] + np.sqrt(1 - AR_PHI**2) * white[rows[k]]
    return sigma * out


def _programme(rng: np.random.Generator, minutes: float) -> tuple[CycleSegment, ...]:
    """Random speed/duty steps (independent, so spindle and nut heating decorrelate)."""
    segments, used = [], 0.0
    while used < minutes:
        length = float(min(rng.uniform(20, 90), minutes - used + 1))
        speed = float(rng.choice([0, 1500, 3000, 4500, 6000, 8000]))
        duty = float(rng.choice([0, 20, 40, 60, 80])) if speed > 0 or rng.random() < 0.3 else 0.0
        segments.append(CycleSegment(length, speed, duty))
        used += length
    return tuple(segments)


def _thermal_configs(s: Scenario, rng: np.random.Generator) -> list[ThermalConfig]:
    configs = []
    for run in range(s.runs):
        train = run < _n_train(s)
        # Draws in this order (day, programme, amplitude, start), as before the extrapolation scenarios.
        extrapolation = s.kind == "extrapolation"  # a still summer air for the train runs, winter for the real ones
        day = rng.uniform(*SUMMER_DAYS) if train else rng.uniform(*(WINTER_DAYS if extrapolation else (0, 365)))
        cycle = _programme(rng, s.run_min)
        amplitude = rng.uniform(0.5, 3.5)
        config = ThermalConfig(
            cycle=cycle,
            ambient=Ambient(day_of_year=day, daily_amplitude_C=0.05 if extrapolation and train else amplitude,
                            start_hour=rng.uniform(6, 14)),
            zero_at_start=False, measurement_noise=0.0,
            sensor_lag=0.0 if s.family == "thermal/features" else 1.0,
        )
        heat = dataclasses.replace(config.heat, chiller_period_min=rng.uniform(30, 60),
                                   chiller_on_fraction=rng.uniform(0.2, 0.4))
        configs.append(dataclasses.replace(config, heat=heat))
    return configs


def _simulate_runs(configs: list[ThermalConfig], seeds: list[int], run_min: float, **override) -> pd.DataFrame:
    tables = []
    for run, (config, seed) in enumerate(zip(configs, seeds)):
        table = simulate_thermal(dataclasses.replace(config, **override), seed=seed)
        tables.append(table[table["time_min"] <= run_min].assign(run=run))
    return pd.concat(tables, ignore_index=True)


def _unrelated_readings(df: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
    """Two readings no node of the machine feels: an electrical cabinet's temperature (a slow random walk
    about a level of its own per run, °C) and the shop's relative humidity (a daily cycle, %)."""
    cabinet, humidity = np.empty(len(df)), np.empty(len(df))
    for run in df["run"].unique():
        rows = np.flatnonzero(df["run"].to_numpy() == run)
        walk = np.cumsum(rng.normal(0.0, 0.03, rows.size))
        cabinet[rows] = rng.uniform(26.0, 34.0) + walk
        phase = rng.uniform(0.0, 2 * np.pi)
        minutes = df["time_min"].to_numpy()[rows]
        humidity[rows] = rng.uniform(35.0, 55.0) + 6.0 * np.sin(2 * np.pi * minutes / 1440.0 + phase)
    return df.assign(cabinet_C=cabinet, humidity_pct=humidity + rng.normal(0.0, 0.3, len(df)))


def label_columns(effect: str, full: pd.DataFrame, alone: pd.DataFrame, same_driver: pd.DataFrame,
                  real: np.ndarray) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Truth and decoy columns of a withheld thermal effect from within-run variance shares on the real rows."""
    def within(table: pd.DataFrame, column: str) -> float:
        values = table.loc[real, column]
        return float(np.var(values - values.groupby(table.loc[real, "run"]).transform("mean")))

    def share(part: pd.DataFrame, column: str) -> float:
        return within(part, column) / within(full, column)

    own = {c: share(alone, c) for c in SENSORS}
    best = max(own, key=own.get)
    truth = {best} if own[best] >= TRUTH_SHARE_MIN else set()
    truth |= set(INPUT_SENSORS.get(effect, ())) | ({DRIVER_OF[effect]} - {None})
    decoys = [c for c in SENSORS if c not in truth and share(same_driver, c) <= DECOY_SHARE_MAX]
    decoys += [d for d in DRIVERS if d not in truth and d != DRIVER_OF[effect]]
    return tuple(sorted(truth, key=lambda c: -own.get(c, 0.0))), tuple(decoys)


def thermal_case(s: Scenario) -> Case:
    """Simulated runs of a thermal scenario with ``prediction_um`` and ``true_effect_um``."""
    rng = np.random.default_rng(s.seed)
    configs = _thermal_configs(s, rng)
    seeds = [int(rng.integers(1 << 31)) for _ in configs]
    features_null = s.family == "thermal/features" and s.effect is None
    # A null's model inputs are noise-free: a noisy input leaves error that a second reading removes.
    df = _simulate_runs(configs, seeds, s.run_min, **({"sensor_noise": 0.0} if features_null else {}))
    if features_null:
        df = _unrelated_readings(df, np.random.default_rng(s.seed + 2))
    real = (df["run"] >= _n_train(s)).to_numpy()
    clean = df[[f"effect_{e}_um" for e in THERMAL_EFFECTS]].sum(axis=1).to_numpy()
    if s.family == "thermal/prediction":
        true_effect = df[f"effect_{s.effect}_um"].to_numpy() if s.effect else np.zeros(len(df))
        df["prediction_um"] = clean - true_effect
        if s.effect is None:
            candidates, truth = tuple(rng.choice(NULL_PREDICTION_POOL, s.n_decoys, replace=False)), ()
        else:
            scales = {e: 0.0 for e in THERMAL_EFFECTS}
            sharing = {e for e in THERMAL_EFFECTS if e == s.effect or
                       (DRIVER_OF[e] is not None and DRIVER_OF[e] == DRIVER_OF[s.effect])}
            alone = _simulate_runs(configs, seeds, s.run_min, sensor_noise=0.0, **(scales | {s.effect: 1.0}))
            same = _simulate_runs(configs, seeds, s.run_min, sensor_noise=0.0, **(scales | dict.fromkeys(sharing, 1.0)))
            truth, decoys = label_columns(s.effect, df, alone, same, real)
            if not truth:
                raise NoRightAnswer(f"{s.name}: no column carries the withheld effect on the real rows (share < "
                                 f"{TRUTH_SHARE_MIN}); the scenario has no right answer")
            picked = rng.choice(decoys, min(s.n_decoys, len(decoys)), replace=False)
            candidates = tuple(rng.permutation([truth[0], *picked]))
    else:
        if s.effect is None:
            true_effect, truth = np.zeros(len(df)), ()
            candidates = tuple(rng.choice(NULL_FEATURES_POOL, min(s.n_decoys, len(NULL_FEATURES_POOL)),
                                          replace=False))
        else:
            node = NODE_OF_SENSOR[s.effect]
            true_effect = 1e3 * EXPANSION_PER_K * NODE_LENGTH_MM[node] * (df[f"true_{node}_C"].to_numpy() - 20.0)
            truth = (s.effect,)
            pool = DECOYS_FEATURES[s.effect]
            candidates = tuple(rng.permutation([s.effect, *rng.choice(pool, min(s.n_decoys, len(pool)), replace=False)]))
    return Case(_add_noise(df, clean, true_effect, s, rng, real), candidates, truth)


def gantry_case(s: Scenario) -> Case:
    """Simulated gantry runs (varied feed, acceleration, warm-up) with the prediction column."""
    rng = np.random.default_rng(s.seed)
    tables = []
    for run in range(s.runs):
        config = GantryConfig(
            feed_mm_min=float(rng.choice([200, 400, 800, 1200])),
            acceleration_mm_s2=float(rng.choice([10, 20, 50])),
            motor_warm_min=float(rng.uniform(0, 60)),
            measurement_noise=0.0,
            motor_noise_C=0.005,
        )
        tables.append(simulate_gantry(config, seed=int(rng.integers(1 << 31))).assign(run=run))
    df = pd.concat(tables, ignore_index=True).rename(columns={"deviation_um": "error_um"})
    clean = df[[c for c in df if c.startswith("effect_")]].sum(axis=1).to_numpy()
    true_effect = df[f"effect_{s.effect}_um"].to_numpy() if s.effect else np.zeros(len(df))
    df["prediction_um"] = clean - true_effect
    truth = GANTRY_TRUTH.get(s.effect, ()) if s.kind == "withheld" else ()
    candidates = GANTRY_CANDIDATES_FOR.get(s.effect, GANTRY_CANDIDATES)
    return Case(_add_noise(df, clean, true_effect, s, rng, (df["run"] >= 1).to_numpy()), candidates, truth)


def _add_noise(df, clean, true_effect, s: Scenario, rng, real: np.ndarray) -> pd.DataFrame:
    """Target = noise-free error + noise of std (identifiable effect std) / SNR (see module docstring)."""
    if s.effect is None:
        sigma = s.null_noise_um
    else:
        runs = pd.get_dummies(df["run"][real]).to_numpy(float)
        design = runs if s.family.endswith("prediction") else \
            np.column_stack([runs, df.loc[real, [c for c in NODE_SENSORS if c != s.effect]].to_numpy()])
        part = true_effect[real] - design @ np.linalg.lstsq(design, true_effect[real], rcond=None)[0]
        sigma = np.std(part) / s.snr
    noise = _noise(len(df), sigma, s.ar, rng, df["run"].to_numpy())
    return df.assign(error_um=clean + noise, noise_true_um=noise, true_effect_um=true_effect)


def axis_case(s: Scenario) -> Case:
    """Laser passes along a linear axis (:func:`svrqp.machine.geometry.simulate_axis`), one per run.

    The train pass is taken at the reference state (20 °C, empty table). Every other pass has
    its own room temperature (``ambient_C``, 19–23 °C), axis temperature (the room plus 0–8 K
    of drive heating, ``axis_C``), table load (``load_kg``) and an unrelated ``humidity_pct``;
    all four are constant through a pass, read with a little noise. The prediction is the
    simulation with the withheld effect off.
    """
    rng = np.random.default_rng(s.seed)
    positions = tuple(np.linspace(0.0, AXIS_TRAVEL_MM, s.positions).tolist())
    tables = []
    for run in range(s.runs):
        room, heat, load = (20.0, 0.0, 0.0) if run == 0 else \
            (rng.uniform(19.0, 23.0), rng.uniform(0.0, 8.0), float(rng.choice([0, 100, 200, 300, 400, 500])))
        config = AxisConfig(positions_mm=positions, axis_temperature_C=room + heat, load_kg=load, measurement_noise=0.0)
        table = simulate_axis(config, seed=int(rng.integers(1 << 31)))
        n = len(table)
        tables.append(table.assign(
            run=run, axis_C=table["axis_C"] + 0.02 * rng.standard_normal(n), load_kg=load,
            ambient_C=room + 0.05 * rng.standard_normal(n), humidity_pct=rng.uniform(30.0, 60.0)))
    df = pd.concat(tables, ignore_index=True)
    clean = df[[f"effect_{e}_um" for e in AXIS_EFFECTS]].sum(axis=1).to_numpy()
    true_effect = df[f"effect_{s.effect}_um"].to_numpy() if s.effect else np.zeros(len(df))
    df["prediction_um"] = clean - true_effect
    truth = AXIS_TRUTH.get(s.effect, ()) if s.kind == "withheld" else ()
    return Case(_add_noise(df, clean, true_effect, s, rng, (df["run"] >= 1).to_numpy()), AXIS_CANDIDATES, truth)


def case_for(s: Scenario) -> Case:
    """The simulated data of a scenario."""
    family = s.family.split("/")[0]
    if s.kind in LOCAL_KINDS:
        return local_case(s)
    case = {"gantry": gantry_case, "axis": axis_case, "thermal": thermal_case}[family](s)
    if s.continuous:  # the runs follow one another on one clock
        order = ORDER[family]
        table = case.table.sort_values(["run", order], kind="stable").reset_index(drop=True)
        table[order] = table[order] + table["run"] * (table[order].max() + 1.0)
        case = dataclasses.replace(case, table=table)
    return case


# ------------------------------------------------------------------------ localised effects


LOCAL_KINDS = ("local", "local-null")
"""Kinds of the localised scenarios: an effect confined to one stretch of the order axis that a
candidate scales (``local``), or one that no candidate carries (``local-null``)."""

LOCAL_DRIVER = {"startup": "speed_rpm", "window": "coolant_C", "zone": "accel_mm_s2", "patch": "ambient_C",
                "load": "load_kg", "speed": "T1_C"}
"""Candidate column that scales each localised effect (the truth of its scenarios)."""

LOCAL_AXIS = {"speed": "speed_rpm"}
"""Column along which a localised effect is confined when it is not the order axis (``speed``: a sensor that
matters only above a spindle speed)."""


def local_axis(s: Scenario) -> str:
    """The column whose stretch ``s.window`` confines the effect."""
    return LOCAL_AXIS.get(s.effect, ORDER[s.family.split("/")[0]])

LOCAL_CANDIDATES = {"thermal": NULL_PREDICTION_POOL, "gantry": GANTRY_CANDIDATES, "axis": AXIS_CANDIDATES}


def window_bounds(table: pd.DataFrame, s: Scenario) -> tuple[float, float]:
    """The local effect's stretch ``[low, high]`` in units of its axis (:func:`local_axis`; fractions of its range)."""
    order = table[local_axis(s)]
    low, high = float(order.min()), float(order.max())
    return low + s.window[0] * (high - low), low + s.window[1] * (high - low)


def local_profile(t: np.ndarray, low: float, high: float, shape: str) -> np.ndarray:
    """The effect's shape along the order axis: zero outside ``[low, high]``, peak 1 inside."""
    inside = (t >= low) & (t <= high)
    u = np.clip((t - low) / (high - low), 0.0, 1.0)
    values = {"indicator": np.ones_like(u), "bump": np.sin(np.pi * u), "transient": np.exp(-3.0 * u)}[shape]
    return np.where(inside, values, 0.0)


def local_case(s: Scenario) -> Case:
    """A family's simulation with nothing withheld, plus an effect confined to ``s.window`` of the order axis.

    ``local``: the effect is the profile times the driver column's departure from its train-rows mean
    (a start-up transient scaled by the spindle speed, a mid-run window scaled by the coolant
    temperature, the gantry's acceleration zone scaled by the commanded acceleration, a guideway
    patch scaled by the room temperature, a load bump scaled by the table load); the truth is the
    driver. ``local-null``: the profile times a random amplitude per run that no column reads. The
    prediction leaves the effect out; the noise is set by the SNR as for every withheld effect.
    """
    family = s.family.split("/")[0]
    base = dataclasses.replace(s, kind="null", effect=None, window=None)
    table = {"gantry": gantry_case, "axis": axis_case, "thermal": thermal_case}[family](base).table
    clean = (table["error_um"] - table["noise_true_um"]).to_numpy()
    rng = np.random.default_rng(s.seed + 1)
    low, high = window_bounds(table, s)
    profile = local_profile(table[local_axis(s)].to_numpy(), low, high, s.shape)
    train = table.eval(train_query(s)).to_numpy()
    if s.kind == "local":
        driver = table[LOCAL_DRIVER[s.effect]].to_numpy()
        reference = driver[train].mean() if family != "gantry" else 0.0  # a sync error scales with acceleration itself
        true_effect = profile * (driver - reference) / max(np.std(driver), 1e-12)
        truth = (LOCAL_DRIVER[s.effect],)
    else:
        amplitude = rng.normal(0.0, 1.0, table["run"].max() + 1)
        true_effect = profile * amplitude[table["run"].to_numpy()]
        truth = ()
    pool = LOCAL_CANDIDATES[family]
    if family == "thermal":
        picked = list(rng.choice([c for c in pool if c not in truth], s.n_decoys, replace=False))
        candidates = tuple(rng.permutation([*truth, *picked]))
    else:
        candidates = pool
    effected = dataclasses.replace(s, effect=s.effect or "disturbance")
    df = table.drop(columns=["error_um", "noise_true_um", "true_effect_um"]).assign(prediction_um=clean)
    return Case(_add_noise(df, clean + true_effect, true_effect, effected, rng, ~train), candidates, truth)


def local_scenarios(design) -> list[Scenario]:
    """At least 30 localised withheld effects and 20 local nulls, across the thermal, gantry and axis families.

    Region widths run from 3 % to 25 % of the order axis, each with at least 5 rows per run:
    thermal runs are sampled every minute (3 % of 240 min is 7 rows), gantry passes at 15 Hz, and
    the axis passes here at 111 positions (5 mm; the narrowest window, 8 %, is 9 rows). Six more,
    ``lt-speed-*``, are confined along the spindle speed instead: ``T1_C`` matters only above 35–70 %
    of the speed range, wherever in the run that is.
    """
    out: list[Scenario] = []
    thermal = {"startup": [(0.0, w) for w in (0.03, 0.05, 0.08, 0.12, 0.15, 0.2, 0.25, 0.1)],
               "window": [(a, a + w) for a, w in ((0.4, 0.05), (0.6, 0.1), (0.2, 0.15), (0.5, 0.25), (0.3, 0.08),
                                                   (0.7, 0.2))]}
    for effect, windows in thermal.items():
        for i, window in enumerate(windows):
            out.append(Scenario(f"lt-{effect}-{i}", "thermal/prediction", "local", effect, n_decoys=4,
                                window=window, shape=("transient" if effect == "startup" else "bump", "indicator")[i % 2],
                                **design(i) | {"seed": design(i)["seed"] + len(out)}))
    for i, w in enumerate((0.03, 0.05, 0.08, 0.1, 0.12, 0.15, 0.2, 0.25)):
        out.append(Scenario(f"lg-zone-{i}", "gantry/prediction", "local", "zone", window=(0.0, w),
                            **design(i) | {"runs": (4, 6, 8)[i % 3], "run_min": 0.0, "seed": design(i)["seed"] + len(out)}))
    axis = {"patch": ((0.1, 0.2), (0.5, 0.58), (0.3, 0.45), (0.7, 0.95), (0.2, 0.32), (0.6, 0.72)),
            "load": ((0.4, 0.6), (0.1, 0.25), (0.45, 0.53), (0.6, 0.85), (0.3, 0.42), (0.05, 0.2))}
    for effect, windows in axis.items():
        for i, window in enumerate(windows):
            out.append(Scenario(f"la-{effect}-{i}", "axis/prediction", "local", effect, window=window,
                                shape=("bump", "indicator")[i % 2],
                                **design(i) | {"runs": (5, 7, 9)[i % 3], "run_min": 0.0, "positions": 111,
                                               "seed": design(i)["seed"] + len(out)}))
    nulls = (("thermal/prediction", 8, {}), ("gantry/prediction", 6, {"run_min": 0.0}),
             ("axis/prediction", 6, {"run_min": 0.0, "positions": 111}))
    for family, count, extra in nulls:
        for i in range(count):
            width = (0.05, 0.1, 0.2, 0.25, 0.08, 0.15)[i % 6]
            start = (0.0, 0.3, 0.6)[i % 3] if not family.startswith("gantry") else 0.0
            runs = {"thermal/prediction": design(i)["runs"], "gantry/prediction": (4, 6, 8)[i % 3],
                    "axis/prediction": (5, 7, 9)[i % 3]}[family]
            out.append(Scenario(f"l0-{family.split('/')[0]}-{i}", family, "local-null", None, n_decoys=4,
                                window=(start, start + width), shape=("bump", "indicator")[i % 2],
                                **design(i) | extra | {"runs": runs, "seed": design(i)["seed"] + len(out)}))
    for i, low in enumerate((0.55, 0.7, 0.35, 0.7, 0.55, 0.35)):  # added last: the seeds above stay as they were
        out.append(Scenario(f"lt-speed-{i}", "thermal/prediction", "local", "speed", n_decoys=4, window=(low, 1.0),
                            **design(i) | {"seed": design(i)["seed"] + len(out)}))
    return out


# ------------------------------------------------------------------------ scenarios


DEVELOPMENT = {"seed": 1000, "snr": (1.0, 2.0, 4.0, 8.0, 1.5), "runs": (3, 5, 4), "run_min": (240.0, 420.0), "ar": 3}
"""The grid the method was developed on."""

HOLDOUT = {"seed": 7000, "snr": (0.75, 3.0, 6.0, 1.25, 2.5), "runs": (4, 3, 6), "run_min": (300.0, 180.0, 480.0),
           "ar": 2}
"""A second grid (other seeds, other levels), held out while developing the first versions."""

FRESH = {"seed": 41000, "snr": (1.0, 0.75, 2.0, 5.0, 1.25), "runs": (3, 4, 5), "run_min": (360.0, 200.0, 300.0),
         "ar": 1}
"""A third grid, seeds unused elsewhere: run only to check changes made on the others, never to tune them."""

CONFIRM = {"seed": 90000, "snr": (1.25, 2.5, 0.75, 4.0, 1.5), "runs": (5, 3, 4), "run_min": (270.0, 390.0, 210.0),
           "ar": 0}
"""A fourth grid, generated after the rise and the between-run t-test were settled on the development grid:
run once and committed as it came (the fresh grid had been run seven times and was no longer fresh)."""

BLIND = {"seed": 150000, "snr": (2.0, 0.75, 3.0, 1.25, 5.0), "runs": (4, 5, 3), "run_min": (330.0, 240.0, 450.0),
         "ar": 1}
"""A fifth grid, generated with the suite's hygiene of DESIGN §4 (the denominator set by the simulator and a
generating-form oracle, noise-free nulls, six runs for a run-level truth): run once, committed as it came."""

SEALED = {"seed": 210000, "snr": (1.5, 4.0, 0.75, 2.5, 1.0), "runs": (5, 4, 3), "run_min": (280.0, 400.0, 220.0),
          "ar": 2}
"""A sixth grid, generated after the local form of a run-level reading that drifts within runs was settled on the
development grid (the blind grid had shown the localised targets missed): run once, committed as it came."""

UNSEEN = {"seed": 260000, "snr": (3.0, 1.0, 6.0, 0.75, 2.0), "runs": (4, 3, 5), "run_min": (360.0, 250.0, 430.0),
          "ar": 3}
"""A seventh grid, generated after a global cause confined to one stretch was withheld (settled on the development
grid and on 400 localised nulls of their own seeds; the sealed grid had been looked at): run once, committed as it
came."""

PRISTINE = {"seed": 320000, "snr": (2.5, 0.75, 1.5, 4.0, 1.0), "runs": (5, 3, 4), "run_min": (300.0, 210.0, 390.0),
            "ar": 0}
"""An eighth grid, generated after the denominator's surrogate test (a truth leaves it when its generating form does
not beat its surrogates, p ≥ 0.05; DESIGN §4) was added, with the engine unchanged since the unseen grid: run once,
committed as it came."""

RESERVE = {"seed": 380000, "snr": (1.25, 3.0, 0.75, 2.0, 5.0), "runs": (4, 5, 3), "run_min": (320.0, 230.0, 410.0),
           "ar": 2}
"""A ninth grid, generated after the window dictionary's half-shifted tiles were settled on the development grid,
400 localised nulls and the localised scenarios of the pristine and unseen grids (both looked at, so development):
run once, committed as it came."""

GRIDS = {"development": DEVELOPMENT, "holdout": HOLDOUT, "fresh": FRESH, "confirm": CONFIRM, "blind": BLIND,
         "sealed": SEALED, "unseen": UNSEEN, "pristine": PRISTINE, "reserve": RESERVE}
"""Every grid by name."""

ORACLE_BLOCKS = 8
"""Contiguous blocks of a continuous record's real rows that the suite's own refits hold out one at a time."""

CONTINUOUS_NULLS = 20
"""Null scenarios recorded as one continuous record, per grid."""


def scenarios(quick: bool = False, grid: str = "development") -> list[Scenario]:
    """The fixed scenario grid of :data:`GRIDS` (deterministic seeds)."""
    out: list[Scenario] = []
    levels = GRIDS[grid]

    def design(i: int) -> dict:
        # Cycle through SNR x runs x record length x noise colour so every effect sees each level.
        return {"snr": levels["snr"][i % 5], "runs": levels["runs"][i % 3],
                "run_min": levels["run_min"][i % len(levels["run_min"])], "ar": i % 4 == levels["ar"],
                "seed": levels["seed"] + len(out)}

    for effect in THERMAL_EFFECTS:
        for i in range(10):
            out.append(Scenario(f"tp-{effect}-{i}", "thermal/prediction", "withheld", effect,
                                n_decoys=4 + i % 3, **design(i)))
    for sensor in DECOYS_FEATURES:
        for i in range(10):
            out.append(Scenario(f"tf-{sensor}-{i}", "thermal/features", "withheld", sensor, n_decoys=3 + i % 3,
                                model="lssvr" if i % 5 == 4 else "mlr", **design(i)))
    for effect in GANTRY_TRUTH:
        for i in range(6):
            out.append(Scenario(f"gp-{effect}-{i}", "gantry/prediction", "withheld", effect,
                                **design(i) | {"runs": (4, 6, 8)[i % 3], "run_min": 0.0}))
    for i in range(12):
        noise = {"null_noise_um": (0.1, 0.3, 1.0)[i % 3]}
        out.append(Scenario(f"tp-null-{i}", "thermal/prediction", "null", None, **design(i) | noise))
        out.append(Scenario(f"tf-null-{i}", "thermal/features", "null", None, n_decoys=4,
                            model="lssvr" if i % 5 == 4 else "mlr", **design(i) | noise))
    for i in range(6):
        out.append(Scenario(f"gp-null-{i}", "gantry/prediction", "null", None, **design(i) | {
            "null_noise_um": (0.05, 0.15, 0.3)[i % 3], "runs": (4, 6, 8)[i % 3], "run_min": 0.0}))
    for effect in GANTRY_UNMEASURED:
        for i in range(4):
            out.append(Scenario(f"gu-{effect}-{i}", "gantry/prediction", "unmeasured", effect,
                                **design(i) | {"runs": (4, 6, 8)[i % 3], "run_min": 0.0}))

    def passes(i: int) -> dict:
        # At least four real passes: a reading constant through each pass is one number per
        # pass, and with three passes a decoy lines up with |r| > 0.99 about one time in eleven.
        return {"runs": (5, 7, 9)[i % 3], "run_min": 0.0, "positions": (23, 56, 12)[i % 3]}

    for effect in AXIS_TRUTH:
        for i in range(6):
            out.append(Scenario(f"ap-{effect}-{i}", "axis/prediction", "withheld", effect, **design(i) | passes(i)))
    for i in range(6):
        out.append(Scenario(f"ap-null-{i}", "axis/prediction", "null", None,
                            **design(i) | passes(i) | {"null_noise_um": (0.1, 0.3, 1.0)[i % 3]}))
    for effect in AXIS_UNMEASURED:
        for i in range(4):
            out.append(Scenario(f"au-{effect}-{i}", "axis/prediction", "unmeasured", effect, **design(i) | passes(i)))
    out += transfer_scenarios(design)
    out += local_scenarios(design)
    # Added last, so that every seed above stays as it was: with six continuous nulls a single chance verdict
    # reads 0.167, and their false-attribution row could not show the 0.05 of its target.
    for i in range(6, CONTINUOUS_NULLS):
        out.append(Scenario(f"tc-null-{i}", "thermal/features", "null", None, n_decoys=4, continuous=True,
                            **design(i) | {"null_noise_um": (0.1, 0.3, 1.0)[i % 3]}))
    # A run-level truth needs six runs (DESIGN §4); the seeds stay as they were.
    out = [dataclasses.replace(s, runs=max(s.runs, MIN_RUN_LEVEL_RUNS)) if s.effect in RUN_LEVEL_EFFECTS else s
           for s in out]
    return out[::10] if quick else out


def transfer_scenarios(design) -> list[Scenario]:
    """Scenarios added with the transfer definition of shrink (DESIGN §4), after the others (their seeds unchanged).

    ``tx-extrapolation-*``: every node sensor is a model input and nothing is withheld, but the train
    runs are a still summer day and the real runs winter days: the ambient input's coefficient was never
    learned, and the right answer is no candidate, with extrapolation named. ``tc-*``: withheld node
    sensors and nulls recorded as one continuous record without runs (no ``--group``).
    """
    out: list[Scenario] = []  # design(i)["seed"] continues the grid's seeds; each scenario adds its index
    for i in range(8):
        out.append(Scenario(f"tx-extrapolation-{i}", "thermal/features", "extrapolation", None, n_decoys=4,
                            **design(i) | {"runs": (4, 5, 6)[i % 3], "seed": design(i)["seed"] + len(out)}))
    for sensor in DECOYS_FEATURES:
        for i in range(3):
            out.append(Scenario(f"tc-{sensor}-{i}", "thermal/features", "withheld", sensor, n_decoys=3 + i % 3,
                                continuous=True, **design(i) | {"seed": design(i)["seed"] + len(out)}))
    for i in range(6):
        out.append(Scenario(f"tc-null-{i}", "thermal/features", "null", None, n_decoys=4, continuous=True,
                            **design(i) | {"null_noise_um": (0.1, 0.3, 1.0)[i % 3],
                                           "seed": design(i)["seed"] + len(out)}))
    return out
