"""Named closed-form test problems of the gap diagnosis (not the simulator: every term is explicit).

Each problem is a table of runs (``run``), sampled once a minute (``time_min``), of a machine
whose spindle temperature ``spindle_C`` follows a speed programme and whose air temperature
``air_C`` drifts; ``coolant_C`` follows the air with a 15 min lag plus its chiller's 45 min
cycle (a correlated decoy) and ``nut_C`` follows its own duty programme (an unrelated decoy).
The error is

.. math::

    e = a\\,T_\\mathrm{spindle} + \\text{effect} + \\nu,\\qquad \\nu \\sim \\mathrm{AR}(1),

with the effect one of: none; ``b``·(air through a first-order lag of ``tau`` min); ``b``·air;
``b``·d(spindle)/dt. The first run is the train run. Lags use :func:`scipy.signal.lfilter`,
independently of :mod:`svrqp.gap.data.transforms`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.signal import lfilter

RUN_MIN = 240
A_SPINDLE_UM_PER_K = 2.0


def first_order_lag(x: np.ndarray, tau: float) -> np.ndarray:
    """Zero-order-hold first-order lag at 1 min sampling, starting in equilibrium."""
    alpha = 1 - np.exp(-1.0 / tau)
    y, _ = lfilter([alpha], [1, -(1 - alpha)], x, zi=[(1 - alpha) * x[0]])
    return y


def _ar1(n: int, sigma: float, phi: float, rng: np.random.Generator) -> np.ndarray:
    shocks = rng.normal(scale=sigma * np.sqrt(1 - phi**2), size=n)
    out, _ = lfilter([1.0], [1.0, -phi], shocks, zi=[phi * rng.normal(scale=sigma)])
    return out


def thermal_runs(effect: str = "none", b: float = 1.0, tau: float = 60.0, runs: int = 4, noise_um: float = 0.3,
                 phi: float = 0.7, seed: int = 0) -> pd.DataFrame:
    """Runs of the closed-form machine with one named effect.

    Parameters
    ----------
    effect : {"none", "air_lag", "air_level", "spindle_rate"}
        The unmodelled effect added to the error.
    b : float
        Its gain (μm/K, or μm per K/min for the rate).
    tau : float
        Time constant of ``air_lag``, min.
    runs : int
        Number of runs; run 0 is the train run.
    noise_um, phi : float
        Standard deviation and lag-1 autocorrelation of the AR(1) probe noise.
    seed : int
        Seed of every random draw.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(RUN_MIN, dtype=float)
    tables = []
    for run in range(runs):
        speed = np.repeat(rng.choice([0.0, 2000.0, 4000.0, 6000.0], size=RUN_MIN // 40 + 1), 40)[:RUN_MIN]
        duty = np.repeat(rng.choice([0.0, 30.0, 60.0], size=RUN_MIN // 50 + 1), 50)[:RUN_MIN]
        air = 18 + 8 * rng.random() + 1.5 * np.sin(2 * np.pi * (t / 300 + rng.random())) + 0.02 * rng.normal(size=RUN_MIN).cumsum()
        spindle = air + first_order_lag(speed / 500, 15)
        coolant = first_order_lag(air, 15) + 0.5 * np.sin(2 * np.pi * (t / 45 + rng.random()))
        nut = air + first_order_lag(duty / 20, 30)
        contribution = {
            "none": np.zeros(RUN_MIN),
            "air_lag": b * first_order_lag(air, tau),
            "air_level": b * air,
            "spindle_rate": b * np.gradient(spindle, t),
        }[effect]
        error = A_SPINDLE_UM_PER_K * spindle + contribution + _ar1(RUN_MIN, noise_um, phi, rng)
        sensor = 0.02
        tables.append(pd.DataFrame({
            "run": f"r{run}", "time_min": t, "speed_rpm": speed,
            "spindle_C": spindle + sensor * rng.normal(size=RUN_MIN),
            "air_C": air + sensor * rng.normal(size=RUN_MIN),
            "coolant_C": coolant + sensor * rng.normal(size=RUN_MIN),
            "nut_C": nut + sensor * rng.normal(size=RUN_MIN),
            "error_um": error, "effect_um": contribution,
        }))
    return pd.concat(tables, ignore_index=True)


def air_lag_problem(seed: int = 1) -> pd.DataFrame:
    """Unmodelled air effect through a 60 min lag, 1.5 μm/K, AR(1) noise 0.3 μm; decoy coolant."""
    return thermal_runs("air_lag", b=1.5, tau=60.0, seed=seed)


def spindle_rate_problem(seed: int = 2) -> pd.DataFrame:
    """Unmodelled thermal-gradient effect, 20 μm per K/min of the (modelled) spindle sensor."""
    return thermal_runs("spindle_rate", b=20.0, seed=seed)


def null_problem(seed: int = 3) -> pd.DataFrame:
    """Nothing unmodelled: the model on ``spindle_C`` is right; only AR(1) noise is left."""
    return thermal_runs("none", seed=seed)


def air_and_shell_problem(seed: int = 0, shell_tau: float = 10.0) -> pd.DataFrame:
    """Unmodelled air effect, 1 μm/K, with a second reading ``shell_C`` of the air through a
    first-order lag of ``shell_tau`` min (a housing that follows the air): the shell's own lead–lag
    filter reproduces the air almost exactly, so the two explain the gap about equally well."""
    df = thermal_runs("air_level", b=1.0, runs=4, seed=seed)
    rng = np.random.default_rng(seed)
    shell = np.concatenate([first_order_lag(run["air_C"].to_numpy(), shell_tau) for _, run in df.groupby("run", sort=False)])
    return df.assign(shell_C=shell + 0.02 * rng.normal(size=len(df)))


CANDIDATES = ["air_C", "coolant_C", "nut_C", "speed_rpm"]
"""Candidates of the closed-form problems (the truth is ``air_C`` for the air effects)."""


AXIS_POSITIONS_MM = np.arange(0.0, 501.0, 10.0)
SCALE_UM_PER_K_MM = 11.5e-3
"""Steel scale expansion, 11.5e-6 /K, in μm per kelvin per millimetre of travel."""


def axis_passes(effect: str = "none", runs: int = 7, noise_um: float = 0.3, seed: int = 0) -> pd.DataFrame:
    """Laser passes along a linear axis, each at its own axis temperature and table load.

    Every pass measures the positioning error at :data:`AXIS_POSITIONS_MM` (``x_mm``, the
    order axis). ``prediction_um`` is the geometric error map, the same for every pass
    (a slope and a smooth wave); ``axis_C`` holds the axis temperature of the pass (constant
    through it, read with 0.01 °C noise), ``load_kg`` and ``humidity_pct`` are further
    per-pass readings unrelated to the error. Pass ``p0`` is the train pass, at 20 °C.

    Parameters
    ----------
    effect : {"none", "scale"}
        ``scale``: the scale's thermal expansion ``SCALE_UM_PER_K_MM * (axis_C - 20) * x_mm``,
        a profile along the pass that the pass's temperature scales.
    runs : int
        Number of passes.
    noise_um : float
        Standard deviation of the white reading noise.
    seed : int
        Seed of every random draw.
    """
    rng = np.random.default_rng(seed)
    x = AXIS_POSITIONS_MM
    geometry = 0.01 * x + 1.5 * np.sin(2 * np.pi * x / 350.0)
    tables = []
    for run in range(runs):
        axis = 20.0 if run == 0 else 20.0 + 8.0 * rng.random()
        contribution = SCALE_UM_PER_K_MM * (axis - 20.0) * x if effect == "scale" else np.zeros(x.size)
        tables.append(pd.DataFrame({
            "run": f"p{run}", "x_mm": x,
            "axis_C": axis + 0.01 * rng.normal(size=x.size),
            "load_kg": float(rng.choice([0.0, 100.0, 200.0, 400.0])),
            "humidity_pct": 35.0 + 20.0 * rng.random(),
            "prediction_um": geometry,
            "error_um": geometry + contribution + noise_um * rng.normal(size=x.size),
            "effect_um": contribution,
        }))
    return pd.concat(tables, ignore_index=True)


AXIS_CANDIDATES = ["axis_C", "load_kg", "humidity_pct"]
"""Candidates of :func:`axis_passes` (the truth is ``axis_C`` for the scale effect)."""


def extrapolation_problem(runs: int = 5, seed: int = 4) -> pd.DataFrame:
    """A model used outside its data, nothing unmodelled among the candidates.

    The error is a gentle curve of one input, :math:`e = 2x + 0.4x^2 + \\nu`; the train run holds
    ``x_C`` within 20 … 22 °C, the real runs within 24 … 30 °C, where a line fitted on the train
    run misses the curve. A refit on more data (the other real runs) takes most of that; the
    candidates ``air_C`` and ``nut_C`` are unrelated random walks.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(RUN_MIN, dtype=float)
    tables = []
    for run in range(runs):
        low, high = (20.0, 22.0) if run == 0 else (24.0 + run, 25.0 + run)
        x = low + (high - low) * (0.5 + 0.5 * np.sin(2 * np.pi * (t / 180 + rng.random())))
        error = 2.0 * x + 0.4 * (x - 20.0) ** 2 + _ar1(RUN_MIN, 0.3, 0.7, rng)
        tables.append(pd.DataFrame({
            "run": f"r{run}", "time_min": t, "x_C": x + 0.02 * rng.normal(size=RUN_MIN),
            "air_C": 20 + 0.05 * rng.normal(size=RUN_MIN).cumsum(),
            "nut_C": 25 + 0.05 * rng.normal(size=RUN_MIN).cumsum(), "error_um": error,
        }))
    return pd.concat(tables, ignore_index=True)
