r"""A fleet of machining centres of one type, each a record for ``svrqp gap`` with its truth.

Every machine is the thermal simulator of :mod:`svrqp.machine.thermal` with its own build
(its spindle, motor and nut heat each scaled by :math:`U(0.8, 1.2)`), its own runs
(random speed and axis-duty programmes, a random day of the year and daily ambient swing) and
its own probe noise. A record holds ``runs`` runs of ``run_min`` minutes each; the first
``train_runs`` are the rows the compensation model was built on. The model is the simulation's
prediction (``prediction_um``): every effect of the machine that the model knows. What a machine
carries beyond it is its *kind*:

``none``
    nothing is withheld: the prediction is right up to the probe noise;
``nut``
    the ball-screw nut heating is withheld (the truth column is ``nut_C``): it acts on the real
    runs only (the machine built its model before the nut wore and ran hot);
``headstock``
    the spindle-motor heating of the headstock is withheld (the truth column is ``T4_C``), on
    the real runs only (a motor that runs hotter since the model was built);
``faulty``
    nothing is withheld, but one candidate sensor (``coolant_C``) is faulty on the real runs:
    it drifts by up to 2 K and jumps by 1 K once per run — a decoy no model may name.

The withheld effect enters ``error_um`` scaled so that the standard deviation of its part that
a per-run offset does not explain, on the real rows, is ``snr`` times the probe noise's:
:math:`e = \hat e + s\,\delta + \nu`, :math:`s = \mathrm{snr}\,\sigma_\nu / \mathrm{sd}(\delta_
\perp)`. The same ``snr`` for every machine of a kind makes a fleet in which an effect is weak
on each machine (no record alone can show it) but common to many.

:func:`fleet_records` yields the machines one at a time (a fleet is never held in memory);
:func:`write_fleet` writes them as CSV files with ``manifest.csv`` (one row per record: its
name and path) and ``truth.csv`` (its kind, truth column, snr and noise) beside them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError
from svrqp.machine.cycles import CycleSegment
from svrqp.machine.thermal import EFFECTS, Ambient, ThermalConfig, simulate_thermal

#: What each kind withholds from the prediction (None: nothing) and the column that carries it.
KINDS: dict[str, tuple[str | None, str | None]] = {
    "none": (None, None),
    "nut": ("nut_heating", "nut_C"),
    "headstock": ("headstock_heating", "T4_C"),
    "faulty": (None, None),
}
#: The candidates every record is diagnosed with (the same for the whole fleet).
CANDIDATES = ("nut_C", "T4_C", "coolant_C", "T9_C")
#: The sensor a ``faulty`` machine has broken.
FAULTY_SENSOR = "coolant_C"
#: The ``svrqp gap`` options of every record of a simulated fleet.
GAP_OPTIONS = {"target": "error_um", "prediction": "prediction_um", "train": "run < 2",
               "candidates": ",".join(CANDIDATES), "order": "time_min", "group": "run"}


@dataclass(frozen=True)
class FleetDesign:
    """How a simulated fleet is drawn.

    Parameters
    ----------
    n
        Number of machines.
    shares
        Kind -> share of the machines (normalised; the rest of the rounding goes to ``none``).
    snr
        Kind -> strength of its withheld effect (see the module docstring).
    runs, train_runs, run_min
        Runs per machine, how many of them the model was built on, minutes per run.
    noise_um
        Range of the machines' probe-noise standard deviations, μm.
    soak_h
        Hours each machine stands before a run (overnight; the simulator's default is 48 h).
    seed
        Seed of the whole fleet (machine ``i`` draws from ``(seed, i)``).
    """

    n: int
    shares: Mapping[str, float] = dataclasses.field(
        default_factory=lambda: {"nut": 0.3, "headstock": 0.2, "faulty": 0.1, "none": 0.4})
    snr: Mapping[str, float] = dataclasses.field(
        default_factory=lambda: {"nut": 2.0, "headstock": 2.0})
    runs: int = 6
    train_runs: int = 2
    run_min: float = 180.0
    noise_um: tuple[float, float] = (0.3, 0.6)
    soak_h: float = 8.0
    seed: int = 0

    def __post_init__(self) -> None:
        unknown = sorted(set(self.shares) - set(KINDS))
        if unknown:
            raise ProblemError(f"fleet shares: unknown kind(s) {unknown}; known: {list(KINDS)}")
        if self.n < 1 or self.runs <= self.train_runs or self.train_runs < 1:
            raise ProblemError(f"fleet: need n >= 1 and runs > train_runs >= 1, got n={self.n}, "
                               f"runs={self.runs}, train_runs={self.train_runs}")

    def kinds(self) -> list[str]:
        """The kind of each machine, in a shuffled order fixed by the seed."""
        total = sum(self.shares.values())
        counts = {k: int(round(self.n * v / total)) for k, v in self.shares.items() if k != "none"}
        extra = sum(counts.values()) - self.n
        if extra > 0:
            raise ProblemError(f"fleet shares round to more than {self.n} machines")
        kinds = [k for k, c in counts.items() for _ in range(c)]
        kinds += ["none"] * (self.n - len(kinds))
        return list(np.random.default_rng([self.seed, 1 << 20]).permutation(kinds))


def _programme(rng: np.random.Generator, minutes: float) -> tuple[CycleSegment, ...]:
    """Random speed and axis-duty steps of 20–90 min (independent of each other)."""
    segments, used = [], 0.0
    while used < minutes:
        length = float(min(rng.uniform(20, 90), minutes - used + 1))
        speed = float(rng.choice([0, 1500, 3000, 4500, 6000, 8000]))
        duty = float(rng.choice([0, 20, 40, 60, 80]))
        segments.append(CycleSegment(length, speed, duty))
        used += length
    return tuple(segments)


def _machine_config(rng: np.random.Generator, soak_h: float) -> ThermalConfig:
    """One machine's build: its spindle, motor and nut heat, each scaled by U(0.8, 1.2)."""
    base = ThermalConfig(measurement_noise=0.0, soak_h=soak_h)
    heat = dataclasses.replace(
        base.heat, spindle_heat_W=base.heat.spindle_heat_W * rng.uniform(0.8, 1.2),
        motor_heat_W=base.heat.motor_heat_W * rng.uniform(0.8, 1.2),
        nut_heat_W=base.heat.nut_heat_W * rng.uniform(0.8, 1.2))
    return dataclasses.replace(base, heat=heat)


def _runs(machine: ThermalConfig, design: FleetDesign, rng: np.random.Generator) -> pd.DataFrame:
    tables = []
    for run in range(design.runs):
        ambient = Ambient(day_of_year=rng.uniform(0, 365), daily_amplitude_C=rng.uniform(0.5, 3.0),
                          start_hour=rng.uniform(6, 14))
        config = dataclasses.replace(machine, cycle=_programme(rng, design.run_min),
                                     ambient=ambient)
        table = simulate_thermal(config, seed=int(rng.integers(1 << 31)))
        tables.append(table[table["time_min"] <= design.run_min].assign(run=run))
    return pd.concat(tables, ignore_index=True)


def _within_sd(values: np.ndarray, runs: np.ndarray) -> float:
    """Standard deviation of ``values`` less their per-run means."""
    means = pd.Series(values).groupby(runs).transform("mean").to_numpy()
    return float(np.std(values - means))


def _break_sensor(table: pd.DataFrame, real: np.ndarray, rng: np.random.Generator) -> None:
    """Make :data:`FAULTY_SENSOR` drift (up to 2 K) and jump (1 K) within each real run."""
    for run in np.unique(table.loc[real, "run"]):
        rows = np.flatnonzero(table["run"].to_numpy() == run)
        ramp = np.linspace(0.0, rng.uniform(-2.0, 2.0), rows.size)
        step = np.where(np.arange(rows.size) >= rng.integers(rows.size // 4, rows.size), 1.0, 0.0)
        table.loc[rows, FAULTY_SENSOR] += ramp + step


def machine_record(design: FleetDesign, index: int, kind: str) -> tuple[pd.DataFrame, dict]:
    """The record of machine ``index`` of the fleet, and its row of the truth table."""
    rng = np.random.default_rng([design.seed, index])
    table = _runs(_machine_config(rng, design.soak_h), design, rng)
    runs = table["run"].to_numpy()
    real = runs >= design.train_runs
    noise_sd = float(rng.uniform(*design.noise_um))
    noise = noise_sd * rng.standard_normal(len(table))
    effect, truth = KINDS[kind]
    known = [f"effect_{e}_um" for e in EFFECTS if e != effect]
    prediction = table[known].sum(axis=1).to_numpy()
    scale = 0.0
    if effect is not None:
        withheld = table[f"effect_{effect}_um"].to_numpy()
        spread = _within_sd(withheld[real], runs[real])
        scale = design.snr.get(kind, 1.0) * noise_sd / spread if spread > 0 else 0.0
        prediction_error = np.where(real, scale * withheld, 0.0)
    else:
        prediction_error = np.zeros(len(table))
    if kind == "faulty":
        _break_sensor(table, real, rng)
    out = table[["run", "time_min", "speed_rpm", "axis_duty_pct", *CANDIDATES]].copy()
    out["prediction_um"] = prediction
    out["error_um"] = prediction + prediction_error + noise
    truth = {"kind": kind, "effect": effect, "truth": truth, "scale": scale,
             "snr": design.snr.get(kind, 0.0) if effect else 0.0, "noise_um": noise_sd}
    return out, truth


def fleet_records(design: FleetDesign) -> Iterator[tuple[str, pd.DataFrame, dict]]:
    """Yield ``(name, record, truth row)`` for each machine, one at a time."""
    width = len(str(design.n - 1))
    for index, kind in enumerate(design.kinds()):
        table, truth = machine_record(design, index, kind)
        yield f"m{index:0{width}d}", table, truth


def write_fleet(folder: str | Path, design: FleetDesign, *, force: bool = False,
                progress: Callable[[int], None] | None = None) -> Path:
    """Write every machine as ``NAME.csv``, with ``manifest.csv`` and ``truth.csv``, in ``folder``.

    The manifest names each record's file and its ``svrqp gap`` options (:data:`GAP_OPTIONS`),
    so ``svrqp fleet FOLDER/manifest.csv --out OUT`` needs no other option. ``progress`` is
    called with the number of machines written. Returns the path of the manifest.
    """
    from svrqp import output

    folder = Path(folder)
    manifest, truths = [], []
    for name, table, truth in fleet_records(design):
        path = folder / f"{name}.csv"
        with output.replacing(path, force=force) as tmp:
            table.to_csv(tmp, index=False)
        manifest.append({"name": name, "path": path.name, **GAP_OPTIONS})
        truths.append({"name": name, **truth})
        if progress is not None:
            progress(len(manifest))
    with output.replacing(folder / "truth.csv", force=force) as tmp:
        pd.DataFrame(truths).to_csv(tmp, index=False)
    with output.replacing(folder / "manifest.csv", force=force) as tmp:
        pd.DataFrame(manifest).to_csv(tmp, index=False)
    return folder / "manifest.csv"
