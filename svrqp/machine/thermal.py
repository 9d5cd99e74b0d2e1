r"""Thermal drift of a machining centre from a lumped-capacitance network, effect by effect.

The machine is a :class:`~svrqp.machine.network.LumpedNetwork` of five nodes — spindle
(bearings and shaft), headstock (spindle housing), column (column and bed), ball-screw nut,
coolant tank — and one boundary, the ambient air. Five physical effects drive it, each a
source of heat or of boundary temperature:

=====================  ==========================================================================
effect                 input
=====================  ==========================================================================
``spindle_heating``    bearing friction :math:`Q_s = Q_{s,0}(n/n_0)^{a}` into the spindle (fast)
``headstock_heating``  motor/drive losses :math:`Q_h = Q_{h,0}(n/n_0)^{b}` into the headstock;
                       it reaches the column through it (slow headstock/column growth)
``nut_heating``        ball-screw nut friction :math:`Q_n = Q_{n,0}\,d(t)` with axis duty
                       :math:`d \in [0, 1]`
``coolant_chiller``    chiller heat extraction :math:`-P_c\,s(t)` from the coolant, with
                       :math:`s(t)` a prescribed on/off square wave (cycling)
``ambient_drift``      ambient deviation :math:`\theta_a(t) = T_a(t) - T_\mathrm{ref}` (seasonal
                       level plus daily cycle), acting through every surface conductance and so
                       through the structure's thermal lag
=====================  ==========================================================================

The network is linear, so the temperature field is the sum of the responses to each effect,
:math:`\theta = \sum_j \theta^{(j)}`, each obtained by integrating the network with that
effect's input alone, starting from its own steady state at the beginning of the soak (the
machine has stood still long enough before the soak). The chiller's on/off pattern is
prescribed, not a thermostat, precisely to keep this superposition exact.

The displacement along the error direction (axial for a vertical spindle) is the sum of the
nodes' free expansions over signed effective lengths :math:`L_i` (mm):

.. math::

   \delta^{(j)}(t) = 10^{3}\,\alpha \sum_i L_i\,\theta_i^{(j)}(t)\ \ [\mu m],\qquad
   e(t) = \sum_j \big(\delta^{(j)}(t) - \delta^{(j)}(0)\big) + \nu(t),

with :math:`\alpha = 11.5\times10^{-6}` /K for steel, the drift counted from the start of the
run as a displacement probe zeroed at ``t = 0`` measures it (ISO 230-3), and
:math:`\nu \sim \mathcal{N}(0, \sigma_\nu^2)` the probe noise. Each term of the sum is a column
``effect_<name>_um`` of the output; ``noise_um`` holds :math:`\nu`; so
``error_um = sum(effect columns) + noise_um`` exactly, and scaling an effect by 0 removes
exactly its column from ``error_um`` (and its share from every temperature).

Sensors read blends of node and ambient temperatures (a sensor on the headstock near the column
reads some of both), pass them through a first-order lag (the sensor's own time constant) and
add white noise. Every effect and the sensor model are scaled by a named field of
:class:`ThermalConfig`; 0 turns it off.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError
from svrqp.machine.cycles import CycleSegment, duration_min, operation_at, warm_up_cool_down
from svrqp.machine.network import LumpedNetwork
from svrqp.machine.signals import first_order_lag

NODES = ("spindle", "headstock", "column", "nut", "coolant")
BOUNDARIES = ("ambient",)
EFFECTS = ("spindle_heating", "headstock_heating", "nut_heating", "coolant_chiller",
           "ambient_drift")
MINUTES_PER_DAY = 1440.0
DAYS_PER_YEAR = 365.0


@dataclass(frozen=True)
class MachineStructure:
    """Heat capacities, conductances and expansion lengths of the five-node machine.

    Defaults give network modes with time constants of about 14 min (spindle), 35 min (nut),
    1.0 and 1.2 h (headstock and coolant tank, coupled) and 7.3 h (column), inside the ranges of
    real machines (spindle 10–40 min, headstock 0.5–2 h, column 3–12 h).

    Lengths are signed effective lengths (mm) along the error direction: a positive length moves
    the tool towards the workpiece when the node warms (spindle shaft, headstock), a negative one
    away from it (the column lifts the headstock).
    """

    spindle_capacity_J_K: float = 6.0e3
    headstock_capacity_J_K: float = 9.0e4
    column_capacity_J_K: float = 7.0e5
    nut_capacity_J_K: float = 2.0e3
    coolant_capacity_J_K: float = 1.6e5
    spindle_coolant_W_K: float = 4.0
    spindle_headstock_W_K: float = 3.0
    headstock_column_W_K: float = 8.0
    headstock_ambient_W_K: float = 12.0
    column_ambient_W_K: float = 22.0
    nut_column_W_K: float = 0.3
    nut_ambient_W_K: float = 0.65
    coolant_ambient_W_K: float = 40.0
    spindle_length_mm: float = 200.0
    headstock_length_mm: float = 250.0
    column_length_mm: float = -350.0
    nut_length_mm: float = 120.0
    expansion_per_K: float = 11.5e-6

    def network(self) -> LumpedNetwork:
        """The :class:`LumpedNetwork` with nodes :data:`NODES` and the ambient boundary."""
        index = {name: i for i, name in enumerate(NODES)}
        G = np.zeros((len(NODES), len(NODES)))
        for (a, b), value in {
            ("spindle", "coolant"): self.spindle_coolant_W_K,
            ("spindle", "headstock"): self.spindle_headstock_W_K,
            ("headstock", "column"): self.headstock_column_W_K,
            ("nut", "column"): self.nut_column_W_K,
        }.items():
            G[index[a], index[b]] = G[index[b], index[a]] = value
        G_b = np.zeros((len(NODES), 1))
        G_b[index["headstock"], 0] = self.headstock_ambient_W_K
        G_b[index["column"], 0] = self.column_ambient_W_K
        G_b[index["nut"], 0] = self.nut_ambient_W_K
        G_b[index["coolant"], 0] = self.coolant_ambient_W_K
        C = np.array([getattr(self, f"{name}_capacity_J_K") for name in NODES])
        return LumpedNetwork(NODES, C, G, BOUNDARIES, G_b)

    def lengths_mm(self) -> np.ndarray:
        """Signed expansion length of each node (the coolant, a fluid, has none), mm."""
        return np.array(
            [self.spindle_length_mm, self.headstock_length_mm, self.column_length_mm,
             self.nut_length_mm, 0.0]
        )


@dataclass(frozen=True)
class HeatSources:
    """Magnitudes of the heat inputs.

    Parameters
    ----------
    spindle_heat_W
        Bearing friction heat at ``reference_speed_rpm``, W; scales as ``(n/n0)**speed_exponent``.
    speed_exponent
        Exponent ``a`` of the bearing heat law (1.3–1.7 for rolling bearings).
    motor_heat_W
        Spindle-motor and drive losses into the headstock at ``reference_speed_rpm``, W.
    motor_speed_exponent
        Exponent ``b`` of the motor-loss law.
    reference_speed_rpm
        Speed ``n0`` at which the two heats above are stated.
    nut_heat_W
        Ball-screw nut friction heat at 100 % axis duty, W.
    chiller_power_W
        Heat the chiller draws from the coolant while it is on, W.
    chiller_period_min
        Period of the chiller's on/off cycle, minutes.
    chiller_on_fraction
        Fraction of each period the chiller is on (it starts a period on).
    """

    spindle_heat_W: float = 45.0
    speed_exponent: float = 1.5
    motor_heat_W: float = 70.0
    motor_speed_exponent: float = 1.0
    reference_speed_rpm: float = 6000.0
    nut_heat_W: float = 12.0
    chiller_power_W: float = 400.0
    chiller_period_min: float = 40.0
    chiller_on_fraction: float = 0.25


@dataclass(frozen=True)
class Ambient:
    r"""Ambient air temperature: a seasonal level plus a daily cycle.

    .. math::

       T_a(t) = \bar T + A_y\cos\!\Big(2\pi\frac{d(t) - d_y}{365}\Big)
                + A_d\cos\!\Big(2\pi\frac{h(t) - h_d}{24}\Big),

    with :math:`d(t)` the day of the year and :math:`h(t)` the clock hour at time ``t``.
    The defaults give about 30 °C on a summer day (day 200); day 280 gives about 24 °C.
    """

    annual_mean_C: float = 22.5
    annual_amplitude_C: float = 7.5
    warmest_day: float = 200.0
    day_of_year: float = 200.0
    daily_amplitude_C: float = 1.0
    warmest_hour: float = 15.0
    start_hour: float = 9.0

    def temperature_C(self, t_min: np.ndarray) -> np.ndarray:
        """Ambient temperature at times ``t_min`` (minutes from the start of the run), °C."""
        t_min = np.asarray(t_min, dtype=float)
        day = self.day_of_year + t_min / MINUTES_PER_DAY
        hour = self.start_hour + t_min / 60.0
        seasonal = self.annual_amplitude_C * np.cos(
            2 * np.pi * (day - self.warmest_day) / DAYS_PER_YEAR
        )
        daily = self.daily_amplitude_C * np.cos(2 * np.pi * (hour - self.warmest_hour) / 24.0)
        return self.annual_mean_C + seasonal + daily


@dataclass(frozen=True)
class Sensor:
    """A temperature sensor: where it sits, how slowly it answers, how noisy it is.

    Parameters
    ----------
    name
        Column name without unit; the output column is ``f"{name}_C"``.
    weights
        Blend of node temperatures (keys from :data:`NODES`) and ``"ambient"`` the sensor reads;
        the weights are >= 0 and sum to 1.
    lag_min
        The sensor's own first-order time constant, minutes (0: none).
    noise_C
        Standard deviation of its white reading noise, °C.
    """

    name: str
    weights: Mapping[str, float]
    lag_min: float = 1.0
    noise_C: float = 0.02

    def __post_init__(self) -> None:
        unknown = sorted(set(self.weights) - set(NODES) - set(BOUNDARIES))
        if unknown:
            raise ProblemError(
                f"sensor {self.name!r}: unknown location(s) {unknown}; "
                f"valid: {list(NODES) + list(BOUNDARIES)}"
            )
        values = np.array(list(self.weights.values()), dtype=float)
        if values.size == 0 or np.any(values < 0) or not np.isclose(values.sum(), 1.0):
            raise ProblemError(f"sensor {self.name!r}: weights must be >= 0 and sum to 1")
        if self.lag_min < 0 or self.noise_C < 0:
            raise ProblemError(f"sensor {self.name!r}: lag_min and noise_C must be >= 0")


# T1 spindle, T2–T8 spindle box, T9 ambient, as in Miao et al. 2013 (S0); T8 sits where the
# headstock joins the column and so carries the slow structural temperature.
DEFAULT_SENSORS: tuple[Sensor, ...] = (
    Sensor("T1", {"spindle": 0.85, "headstock": 0.15}, lag_min=1.0),
    Sensor("T2", {"spindle": 0.5, "headstock": 0.5}, lag_min=1.5),
    Sensor("T3", {"spindle": 0.25, "headstock": 0.75}, lag_min=1.5),
    Sensor("T4", {"headstock": 1.0}, lag_min=2.0),
    Sensor("T5", {"headstock": 0.8, "ambient": 0.2}, lag_min=2.0),
    Sensor("T6", {"headstock": 0.6, "column": 0.4}, lag_min=2.0),
    Sensor("T7", {"headstock": 0.7, "spindle": 0.3}, lag_min=2.0),
    Sensor("T8", {"headstock": 0.2, "column": 0.8}, lag_min=2.0),
    Sensor("T9", {"ambient": 1.0}, lag_min=3.0, noise_C=0.03),
    Sensor("coolant", {"coolant": 1.0}, lag_min=0.5),
    Sensor("nut", {"nut": 0.9, "column": 0.1}, lag_min=1.0),
    Sensor("bed", {"column": 1.0}, lag_min=2.0),
    Sensor("ambient", {"ambient": 1.0}, lag_min=8.0, noise_C=0.05),
)


@dataclass(frozen=True)
class ThermalConfig:
    """Everything the thermal simulator needs; every physical effect has its own scale.

    Parameters
    ----------
    spindle_heating, headstock_heating, nut_heating, coolant_chiller, ambient_drift
        Scale of each physical effect (see the module docstring): 1 as configured, 0 off.
        A scale multiplies the effect's input, so it scales the effect's share of every
        temperature and its ``effect_<name>_um`` column alike.
    sensor_lag
        Scale of every sensor's time constant (0: ideal sensors that follow at once).
    sensor_noise
        Scale of every sensor's noise (0: noise-free temperatures).
    measurement_noise
        Scale of the displacement-probe noise ``noise_um``.
    cycle
        Operating programme from ``t = 0`` (see :mod:`svrqp.machine.cycles`).
    ambient, structure, heat
        Ambient model, network and expansion lengths, heat-source magnitudes.
    sensors
        Sensors read into the output, in column order.
    dt_min
        Integration step, minutes; inputs are held constant over each step.
    sample_min
        Output sampling period, minutes (an integer multiple of ``dt_min``).
    soak_h
        Hours the machine stands still (ambient and chiller still acting) before ``t = 0``.
    reference_C
        Reference temperature at which the machine has its nominal geometry, °C.
    measurement_noise_um
        Standard deviation of the displacement-probe noise, μm.
    zero_at_start
        Count the drift from ``t = 0`` (a probe zeroed at the start), otherwise from the
        machine at ``reference_C``.
    """

    spindle_heating: float = 1.0
    headstock_heating: float = 1.0
    nut_heating: float = 1.0
    coolant_chiller: float = 1.0
    ambient_drift: float = 1.0
    sensor_lag: float = 1.0
    sensor_noise: float = 1.0
    measurement_noise: float = 1.0
    cycle: tuple[CycleSegment, ...] = field(
        default_factory=lambda: warm_up_cool_down(6000.0, 240.0, 120.0, axis_duty_pct=30.0)
    )
    ambient: Ambient = field(default_factory=Ambient)
    structure: MachineStructure = field(default_factory=MachineStructure)
    heat: HeatSources = field(default_factory=HeatSources)
    sensors: tuple[Sensor, ...] = DEFAULT_SENSORS
    dt_min: float = 0.5
    sample_min: float = 1.0
    soak_h: float = 48.0
    reference_C: float = 20.0
    measurement_noise_um: float = 0.3
    zero_at_start: bool = True

    def __post_init__(self) -> None:
        for name in (*EFFECTS, "sensor_lag", "sensor_noise", "measurement_noise"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ProblemError(f"{name}: effect scale must be finite and >= 0, got {value}")
        if not (self.dt_min > 0 and self.sample_min > 0 and self.soak_h >= 0):
            raise ProblemError("dt_min and sample_min must be > 0 and soak_h >= 0")
        ratio = self.sample_min / self.dt_min
        if abs(ratio - round(ratio)) > 1e-9:
            raise ProblemError(
                f"sample_min ({self.sample_min}) must be an integer multiple of dt_min "
                f"({self.dt_min})"
            )
        if not self.cycle:
            raise ProblemError("cycle: at least one segment is required")
        names = [sensor.name for sensor in self.sensors]
        if len(set(names)) != len(names):
            raise ProblemError(f"sensors: duplicate names in {names}")
        if self.measurement_noise_um < 0:
            raise ProblemError("measurement_noise_um must be >= 0")


def effect_inputs(config: ThermalConfig, t_min: np.ndarray) -> np.ndarray:
    """Network inputs of each effect at times ``t_min``, scaled by the effect's scale.

    Returns
    -------
    numpy.ndarray
        Shape ``(len(t_min), len(NODES) + 1, len(EFFECTS))``: for each time and effect, the
        heat into each node (W) followed by the ambient deviation from ``reference_C`` (K).
    """
    t_min = np.asarray(t_min, dtype=float)
    heat = config.heat
    node = {name: i for i, name in enumerate(NODES)}
    ambient_row = len(NODES)
    speed_rpm, duty_pct = operation_at(config.cycle, t_min)
    relative_speed = speed_rpm / heat.reference_speed_rpm
    phase = np.mod(t_min, heat.chiller_period_min) / heat.chiller_period_min
    chiller_on = (phase < heat.chiller_on_fraction).astype(float)

    u = np.zeros((t_min.size, len(NODES) + 1, len(EFFECTS)))
    j = {name: k for k, name in enumerate(EFFECTS)}
    u[:, node["spindle"], j["spindle_heating"]] = (
        heat.spindle_heat_W * relative_speed**heat.speed_exponent
    )
    u[:, node["headstock"], j["headstock_heating"]] = (
        heat.motor_heat_W * relative_speed**heat.motor_speed_exponent
    )
    u[:, node["nut"], j["nut_heating"]] = heat.nut_heat_W * duty_pct / 100.0
    u[:, node["coolant"], j["coolant_chiller"]] = -heat.chiller_power_W * chiller_on
    u[:, ambient_row, j["ambient_drift"]] = config.ambient.temperature_C(t_min) - config.reference_C
    scales = np.array([getattr(config, name) for name in EFFECTS])
    return u * scales


def simulate_thermal(
    config: ThermalConfig | None = None,
    seed: int = 0,
    progress: Callable[[float], None] | None = None,
) -> pd.DataFrame:
    """Simulate a thermal-drift run.

    Parameters
    ----------
    config
        The machine, its operation and which effects are on; default :class:`ThermalConfig`.
    seed
        Seed of the :class:`numpy.random.Generator` drawing sensor and probe noise. The noise
        is drawn the same way whatever the effect scales, so runs that differ only in effects
        share their noise.
    progress
        Called with the fraction of the integration done (0–1).

    Returns
    -------
    pandas.DataFrame
        ``time_min``, ``speed_rpm``, ``axis_duty_pct``, one ``<sensor>_C`` column per sensor,
        ``error_um``, one ``effect_<name>_um`` column per effect in :data:`EFFECTS`,
        ``noise_um``, and the true node temperatures ``true_<node>_C``.
    """
    config = ThermalConfig() if config is None else config
    rng = np.random.default_rng(seed)
    network = config.structure.network()
    dt = config.dt_min
    soak_steps = int(round(config.soak_h * 60.0 / dt))
    run_steps = int(np.ceil(duration_min(config.cycle) / dt - 1e-9))
    t_grid = (np.arange(soak_steps + run_steps + 1) - soak_steps) * dt

    inputs = effect_inputs(config, t_grid)  # (steps+1, nodes+1, effects)
    theta0 = network.steady_state(inputs[0, : len(NODES)], inputs[0, len(NODES) :])
    steps = len(t_grid) - 1
    report = None if progress is None else (lambda done: progress(done / max(steps, 1)))
    theta = network.simulate(inputs[:-1], dt, theta0, progress=report)  # (steps+1, nodes, effects)
    ambient_K = inputs[:, len(NODES)]  # (steps+1, effects)

    stride = int(round(config.sample_min / dt))
    out = np.arange(soak_steps, len(t_grid), stride)
    t_out = t_grid[out]

    lengths_mm = config.structure.lengths_mm()
    displacement_um = 1e3 * config.structure.expansion_per_K * np.einsum(
        "i,tij->tj", lengths_mm, theta[out]
    )
    if config.zero_at_start:
        displacement_um = displacement_um - displacement_um[0]

    total_theta = theta.sum(axis=2)
    total_ambient = ambient_K.sum(axis=1)
    readings = _sensor_readings(config, total_theta, total_ambient, out, rng)
    noise_um = (
        rng.standard_normal(out.size) * config.measurement_noise_um * config.measurement_noise
    )

    speed_rpm, duty_pct = operation_at(config.cycle, t_out)
    table = {"time_min": t_out, "speed_rpm": speed_rpm, "axis_duty_pct": duty_pct}
    table.update(readings)
    table["error_um"] = displacement_um.sum(axis=1) + noise_um
    for k, name in enumerate(EFFECTS):
        table[f"effect_{name}_um"] = displacement_um[:, k]
    table["noise_um"] = noise_um
    for i, name in enumerate(NODES):
        table[f"true_{name}_C"] = config.reference_C + total_theta[out, i]
    return pd.DataFrame(table)


def _sensor_readings(
    config: ThermalConfig,
    theta: np.ndarray,
    ambient_K: np.ndarray,
    out: np.ndarray,
    rng: np.random.Generator,
) -> dict[str, np.ndarray]:
    """Lagged, noisy sensor temperatures (°C) at the output indices ``out``."""
    locations = {name: theta[:, i] for i, name in enumerate(NODES)}
    locations["ambient"] = ambient_K
    # Drawn for every sensor whatever the scales, so the noise stream never depends on them.
    noise = rng.standard_normal((out.size, len(config.sensors)))
    readings = {}
    for s, sensor in enumerate(config.sensors):
        blend = sum(weight * locations[where] for where, weight in sensor.weights.items())
        lagged = first_order_lag(blend, config.dt_min, sensor.lag_min * config.sensor_lag)
        reading = (
            config.reference_C + lagged[out] + noise[:, s] * sensor.noise_C * config.sensor_noise
        )
        readings[f"{sensor.name}_C"] = reading
    return readings

