r"""Geometric errors of a linear axis and their laser-interferometer nine-line measurement (S2).

A carriage travelling along X has six error components at each position :math:`x`:
positioning :math:`\delta_x`, straightnesses :math:`\delta_y, \delta_z` (μm) and roll, pitch,
yaw :math:`\theta_x, \theta_y, \theta_z` (μrad). Each is a sum of named effects, each a smooth
function of :math:`u = x/L` (:math:`L` the travel) with a realistic size and a scale in
:class:`AxisConfig` (0 turns it off):

=====================  ===========================================================================
effect                 contribution
=====================  ===========================================================================
``positioning``        :math:`\delta_x \mathrel{+}= s\,x/1000 + P_x\,p_x(u)` — scale mismatch
                       :math:`s` (μm/m) plus a smooth non-linear part
``periodic``           :math:`\delta_x \mathrel{+}= a\sin(2\pi x/\lambda)` — ball-screw lead error
``straightness_y/z``   :math:`\delta_{y,z} \mathrel{+}= S_{y,z}\,p_{y,z}(u)`
``roll, pitch, yaw``   :math:`\theta_{x,y,z} \mathrel{+}= \Theta_{x,y,z}\,p_{\theta}(u)`
``scale_thermal``      :math:`\delta_x \mathrel{+}= 10^{3}\alpha\,(T - T_\mathrm{ref})\,x`
                       — the scale expands with the axis temperature
``load_deflection``    :math:`\delta_z \mathrel{+}= -\tfrac{w}{2}(1 - \cos 2\pi u)`,
                       :math:`\theta_y \mathrel{+}= -10^{3}\,\mathrm{d}\delta_z/\mathrm{d}x`
                       — guideway sag :math:`w = m g / k` at mid travel under the table
                       load, flat at both ends where the guideway is supported
=====================  ===========================================================================

Each :math:`p(u)` is a random smooth curve (Legendre polynomials of degree 1–4 with seeded
coefficients), zero at :math:`u = 0` and scaled to a peak-to-valley of 1 over the travel, so
the sizes :math:`P, S, \Theta` are peak-to-valley values. Angles are given in arcseconds in the
config and returned in μrad (1″ = 4.848 μrad).

The interferometer along line :math:`k` sees the point offset :math:`(x_k, y_k, z_k)` mm from
the carriage reference (small-angle rigid-body kinematics, S2):

.. math::

   \Delta x_k &= \delta_x - 10^{-3} y_k\theta_z + 10^{-3} z_k\theta_y \\
   \Delta y_k &= \delta_y + 10^{-3} x_k\theta_z - 10^{-3} z_k\theta_x \\
   \Delta z_k &= \delta_z - 10^{-3} x_k\theta_y + 10^{-3} y_k\theta_x

plus white reading noise. The original set measures :math:`\Delta x` on lines 1–3,
:math:`\Delta y` on lines 1–2 and :math:`\Delta z` on line 1; the improved set all nine.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pandas as pd
from numpy.polynomial import legendre

from svrqp.exceptions import ProblemError

COMPONENTS = (
    "delta_x_um", "delta_y_um", "delta_z_um", "theta_x_urad", "theta_y_urad", "theta_z_urad",
)
EFFECTS = (
    "positioning", "periodic", "straightness_y", "straightness_z", "roll", "pitch", "yaw",
    "scale_thermal", "load_deflection",
)
URAD_PER_ARCSEC = np.pi / 648000.0 * 1e6
GRAVITY_M_S2 = 9.80665
MM_URAD_TO_UM = 1e-3
# Which readings each measurement set takes: rows are lines 1–3, columns dx, dy, dz.
MEASURED = {
    "original": np.array([[True, True, True], [True, True, False], [True, False, False]]),
    "improved": np.ones((3, 3), dtype=bool),
}


@dataclass(frozen=True)
class MeasuringLine:
    """Offset (mm) of an interferometer measuring point from the carriage reference point."""

    x_off_mm: float
    y_off_mm: float
    z_off_mm: float


# Three non-collinear points, lines 1 and 2 at different heights, so both sets identify all six.
DEFAULT_LINES = (
    MeasuringLine(0.0, 0.0, 200.0),
    MeasuringLine(100.0, 0.0, 0.0),
    MeasuringLine(-100.0, 200.0, 0.0),
)


@dataclass(frozen=True)
class AxisConfig:
    """A linear axis, its error sizes, and its nine-line measurement.

    Parameters
    ----------
    positioning, periodic, straightness_y, straightness_z, roll, pitch, yaw, scale_thermal, \
load_deflection
        Scale of each effect (see the module docstring); 1 as configured, 0 off.
    measurement_noise
        Scale of the interferometer reading noise.
    travel_mm
        Axis travel :math:`L`, mm.
    positions_mm
        Measured positions along the axis, mm (S2: 11 positions over 0–550 mm).
    positioning_slope_um_per_m
        Linear positioning error (scale mismatch), μm per metre of travel (typ. 5–30).
    positioning_shape_um
        Peak-to-valley of the smooth non-linear positioning error, μm.
    periodic_amplitude_um, periodic_period_mm
        Amplitude (μm) and wavelength (mm, the screw lead) of the periodic positioning error.
    straightness_y_um, straightness_z_um
        Peak-to-valley straightnesses, μm (typ. 2–15).
    roll_arcsec, pitch_arcsec, yaw_arcsec
        Peak-to-valley angular errors, arcseconds (roll 1–10, pitch and yaw 2–20).
    shape_seed
        Seed of the smooth error shapes: a different seed is a different machine.
    axis_temperature_C, reference_C, scale_expansion_per_K
        Temperature of the scale during the measurement, the reference temperature, and the
        scale's expansion coefficient (steel 11.5e-6 /K).
    load_kg, guideway_stiffness_N_um
        Table load and the guideway's effective vertical stiffness, giving the sag
        :math:`w = m g / k` at mid travel.
    lines
        The three measuring lines.
    laser_noise_um
        Standard deviation of each interferometer reading, μm.
    tool_y_mm, tool_z_mm
        Offset of the tool point from the carriage reference, for the tool-point positioning
        error of :func:`simulate_axis` (Abbe offsets).
    """

    positioning: float = 1.0
    periodic: float = 1.0
    straightness_y: float = 1.0
    straightness_z: float = 1.0
    roll: float = 1.0
    pitch: float = 1.0
    yaw: float = 1.0
    scale_thermal: float = 1.0
    load_deflection: float = 1.0
    measurement_noise: float = 1.0
    travel_mm: float = 550.0
    positions_mm: tuple[float, ...] = tuple(np.linspace(0.0, 550.0, 11).tolist())
    positioning_slope_um_per_m: float = 15.0
    positioning_shape_um: float = 4.0
    periodic_amplitude_um: float = 1.0
    periodic_period_mm: float = 16.0
    straightness_y_um: float = 8.0
    straightness_z_um: float = 6.0
    roll_arcsec: float = 4.0
    pitch_arcsec: float = 10.0
    yaw_arcsec: float = 8.0
    shape_seed: int = 2
    axis_temperature_C: float = 22.0
    reference_C: float = 20.0
    scale_expansion_per_K: float = 11.5e-6
    load_kg: float = 300.0
    guideway_stiffness_N_um: float = 1000.0
    lines: tuple[MeasuringLine, ...] = field(default=DEFAULT_LINES)
    laser_noise_um: float = 0.1
    tool_y_mm: float = 0.0
    tool_z_mm: float = 150.0

    def __post_init__(self) -> None:
        for name in (*EFFECTS, "measurement_noise"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ProblemError(f"{name}: effect scale must be finite and >= 0, got {value}")
        if not self.travel_mm > 0:
            raise ProblemError(f"travel_mm must be > 0, got {self.travel_mm}")
        positions = np.asarray(self.positions_mm, dtype=float)
        if positions.size == 0 or np.any(positions < 0) or np.any(positions > self.travel_mm):
            raise ProblemError(f"positions_mm must be non-empty and lie within [0, "
                               f"{self.travel_mm}]")
        if len(self.lines) != 3:
            raise ProblemError(
                f"lines: the nine-line method needs exactly 3 lines, got {len(self.lines)}"
            )
        if self.periodic_period_mm <= 0 or self.guideway_stiffness_N_um <= 0:
            raise ProblemError("periodic_period_mm and guideway_stiffness_N_um must be > 0")
        if self.laser_noise_um < 0:
            raise ProblemError("laser_noise_um must be >= 0")


def smooth_shape(u: np.ndarray, seed: int) -> np.ndarray:
    """A smooth random curve on ``u`` in [0, 1]: zero at 0, peak-to-valley 1 over [0, 1]."""
    rng = np.random.default_rng(seed)
    degrees = np.arange(1, 5)
    coefficients = np.r_[0.0, rng.standard_normal(degrees.size) / degrees]
    grid = np.linspace(0.0, 1.0, 1001)
    on_grid = legendre.legval(2 * grid - 1, coefficients)
    span = on_grid.max() - on_grid.min()
    return (legendre.legval(2 * np.asarray(u) - 1, coefficients) - on_grid[0]) / span


def effect_components(config: AxisConfig, x_mm: np.ndarray) -> dict[str, np.ndarray]:
    """Each effect's contribution to the six components at positions ``x_mm``.

    Returns
    -------
    dict
        Effect name → array of shape ``(len(x_mm), 6)`` in the order of :data:`COMPONENTS`,
        already multiplied by the effect's scale.
    """
    x = np.asarray(x_mm, dtype=float)
    u = x / config.travel_mm
    shape = {i: smooth_shape(u, config.shape_seed * 100 + i) for i in range(6)}
    zero = np.zeros((x.size, 6))

    def only(component: int, values: np.ndarray) -> np.ndarray:
        out = zero.copy()
        out[:, component] = values
        return out

    sag_um = config.load_kg * GRAVITY_M_S2 / config.guideway_stiffness_N_um
    load = zero.copy()
    load[:, 2] = -0.5 * sag_um * (1 - np.cos(2 * np.pi * u))
    # theta_y = -d(delta_z)/dx, with μm/mm = 1e3 μrad.
    load[:, 4] = 1e3 * sag_um * np.pi / config.travel_mm * np.sin(2 * np.pi * u)
    contributions = {
        "positioning": only(
            0,
            config.positioning_slope_um_per_m * x / 1000.0 + config.positioning_shape_um * shape[0],
        ),
        "periodic": only(
            0, config.periodic_amplitude_um * np.sin(2 * np.pi * x / config.periodic_period_mm)
        ),
        "straightness_y": only(1, config.straightness_y_um * shape[1]),
        "straightness_z": only(2, config.straightness_z_um * shape[2]),
        "roll": only(3, config.roll_arcsec * URAD_PER_ARCSEC * shape[3]),
        "pitch": only(4, config.pitch_arcsec * URAD_PER_ARCSEC * shape[4]),
        "yaw": only(5, config.yaw_arcsec * URAD_PER_ARCSEC * shape[5]),
        "scale_thermal": only(
            0,
            1e3
            * config.scale_expansion_per_K
            * (config.axis_temperature_C - config.reference_C)
            * x,
        ),
        "load_deflection": load,
    }
    return {name: getattr(config, name) * contributions[name] for name in EFFECTS}


def true_components(config: AxisConfig | None = None,
                    x_mm: np.ndarray | None = None) -> pd.DataFrame:
    """The six error components, ``x_mm`` plus :data:`COMPONENTS`, at ``x_mm``.

    ``x_mm`` defaults to the configured measuring positions.
    """
    config = AxisConfig() if config is None else config
    x = np.asarray(config.positions_mm if x_mm is None else x_mm, dtype=float)
    total = sum(effect_components(config, x).values())
    return pd.DataFrame({"x_mm": x, **{name: total[:, i] for i, name in enumerate(COMPONENTS)}})


def line_readings(components: np.ndarray, offset_mm: MeasuringLine) -> np.ndarray:
    """Noise-free readings ``(dx, dy, dz)`` in μm on one line; ``components`` is ``(n, 6)``."""
    d_x, d_y, d_z, t_x, t_y, t_z = components.T
    x_k, y_k, z_k = offset_mm.x_off_mm, offset_mm.y_off_mm, offset_mm.z_off_mm
    return np.column_stack([
        d_x - MM_URAD_TO_UM * y_k * t_z + MM_URAD_TO_UM * z_k * t_y,
        d_y + MM_URAD_TO_UM * x_k * t_z - MM_URAD_TO_UM * z_k * t_x,
        d_z - MM_URAD_TO_UM * x_k * t_y + MM_URAD_TO_UM * y_k * t_x,
    ])


def measure_nine_line(
    config: AxisConfig | None = None,
    method: Literal["original", "improved"] = "improved",
    seed: int = 0,
) -> pd.DataFrame:
    """Simulate a laser-interferometer nine-line measurement of the axis.

    Parameters
    ----------
    config
        The axis; default :class:`AxisConfig`.
    method
        ``"original"`` (six readings per position) or ``"improved"`` (all nine).
    seed
        Seed of the reading noise; noise is drawn for all nine readings whatever the method,
        so the two sets of one seed share the readings they have in common.

    Returns
    -------
    pandas.DataFrame
        One row per (position, line): ``x_mm, line, x_off_mm, y_off_mm, z_off_mm, dx_um,
        dy_um, dz_um``; NaN where the set does not measure a quantity.
    """
    config = AxisConfig() if config is None else config
    if method not in MEASURED:
        raise ProblemError(f"method must be one of {sorted(MEASURED)}, got {method!r}")
    x = np.asarray(config.positions_mm, dtype=float)
    epsilon = true_components(config, x)[list(COMPONENTS)].to_numpy()
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal((x.size, 3, 3)) * config.laser_noise_um * config.measurement_noise
    readings = np.stack([line_readings(epsilon, line) for line in config.lines], axis=1) + noise
    readings[:, ~MEASURED[method]] = np.nan
    offsets = np.array([[line.x_off_mm, line.y_off_mm, line.z_off_mm] for line in config.lines])
    return pd.DataFrame({
        "x_mm": np.repeat(x, 3),
        "line": np.tile([1, 2, 3], x.size),
        "x_off_mm": np.tile(offsets[:, 0], x.size),
        "y_off_mm": np.tile(offsets[:, 1], x.size),
        "z_off_mm": np.tile(offsets[:, 2], x.size),
        "dx_um": readings[:, :, 0].ravel(),
        "dy_um": readings[:, :, 1].ravel(),
        "dz_um": readings[:, :, 2].ravel(),
    })


def simulate_axis(config: AxisConfig | None = None, seed: int = 0) -> pd.DataFrame:
    """Tool-point positioning error along the axis, effect by effect.

    The error is the X reading of an interferometer aimed at the tool point
    ``(0, tool_y_mm, tool_z_mm)``: :math:`e = \\delta_x - 10^{-3}y_t\\theta_z + 10^{-3}z_t\\theta_y`
    plus reading noise, so pitch and yaw enter through the Abbe offsets; straightness and roll
    do not enter (their columns are zero).

    Returns
    -------
    pandas.DataFrame
        ``x_mm``, ``axis_C``, ``error_um``, one ``effect_<name>_um`` per effect in
        :data:`EFFECTS`, and ``noise_um``; ``error_um`` equals their sum.
    """
    config = AxisConfig() if config is None else config
    x = np.asarray(config.positions_mm, dtype=float)
    tool = MeasuringLine(0.0, config.tool_y_mm, config.tool_z_mm)
    rng = np.random.default_rng(seed)
    noise_um = rng.standard_normal(x.size) * config.laser_noise_um * config.measurement_noise
    table = {"x_mm": x, "axis_C": np.full(x.size, config.axis_temperature_C)}
    effects = {name: line_readings(part, tool)[:, 0]
               for name, part in effect_components(config, x).items()}
    table["error_um"] = sum(effects.values()) + noise_um
    table.update({f"effect_{name}_um": values for name, values in effects.items()})
    table["noise_um"] = noise_um
    return pd.DataFrame(table)
