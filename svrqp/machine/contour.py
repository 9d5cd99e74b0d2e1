r"""Straightness deviation of a 2X/Y gantry during a linear interpolation (S4, Lin et al. 2011).

The commanded path runs from :math:`(0, 0)` to :math:`(X, Y)` (S4: 150 mm by 4 mm) along the unit
direction :math:`(\cos\varphi, \sin\varphi)` with a trapezoidal speed profile (feed :math:`F`,
acceleration :math:`a`), after and before a dwell at standstill. A laser interferometer in
2D time-base mode samples the actual position at 15 Hz. The deviation is the actual position's
distance from the commanded line along the normal :math:`n = (-\sin\varphi, \cos\varphi)`:

.. math:: e(t) = 10^{3}\, n\cdot(p_\mathrm{actual}(t) - p_\mathrm{cmd}(t)) \ [\mu m]
          = \sum_j e^{(j)}(t) + \nu(t).

Effects (each scaled by a field of :class:`GantryConfig`, 0 off):

``guideway_straightness``
    :math:`S\,p(x/X)`: the X guideway's straightness in Y, a smooth curve of peak-to-valley
    :math:`S` (same construction as :func:`svrqp.machine.geometry.smooth_shape`).
``sync_error``
    The two X drives lag each other by :math:`\Delta = c_s\,\tilde a_x(t)` (unequal loads),
    :math:`\tilde a_x` the X acceleration seen through the X position loop; the beam yaws by
    :math:`\Delta/B` (:math:`B` the span) and the tool, :math:`d` ahead of the beam axis, moves
    by :math:`d\Delta/B` in Y — so it is largest while accelerating.
``servo_lag``
    Each axis follows its command through a proportional position loop,
    :math:`\dot e_i = v_i - K_{v,i} e_i`; with :math:`K_{v,x} \ne K_{v,y}` the lags
    :math:`v_i/K_{v,i}` differ and push the tool off the line by
    :math:`v\sin\varphi\cos\varphi\,(1/K_{v,x} - 1/K_{v,y})` at constant feed.
``ripple``
    Linear-motor force ripple: :math:`A\sin(2\pi s/\lambda + \phi_0)` along the path length
    :math:`s` (pole pitch :math:`\lambda`), a high-frequency ripple of about 2 μm peak-to-peak.
``motor_heating``
    The X motors warm the base, bowing the guideway:
    :math:`b\,\Delta T_m(t)\,4u(1-u)`, :math:`u = x/X`, with
    :math:`\Delta T_m(t) = \Delta T_\infty(1 - e^{-(t + t_w)/\tau_m})` after a warm-up
    :math:`t_w`; ``motor_C`` reads the motor temperature.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError
from svrqp.machine.geometry import smooth_shape
from svrqp.machine.signals import first_order_lag

EFFECTS = ("guideway_straightness", "sync_error", "servo_lag", "ripple", "motor_heating")
SERVO_STEP_S = 1e-3  # internal step of the position-loop model


@dataclass(frozen=True)
class GantryConfig:
    """A 2X/Y gantry, its linear interpolation and the effects that bend the path.

    Parameters
    ----------
    guideway_straightness, sync_error, servo_lag, ripple, motor_heating
        Scale of each effect (module docstring); 1 as configured, 0 off.
    measurement_noise
        Scale of the laser reading noise ``noise_um``.
    stroke_x_mm, stroke_y_mm
        The interpolated line's extent in X and Y, mm (S4: 150 and 4).
    feed_mm_min
        Path feed, mm/min (S4: 400).
    acceleration_mm_s2
        Path acceleration and deceleration, mm/s² (the controller's effective value).
    dwell_s
        Standstill recorded before the start and after the end, s.
    sample_hz
        Interferometer time base, Hz (S4: 15).
    straightness_um, shape_seed
        Peak-to-valley of the guideway straightness, μm, and the seed of its shape.
    kv_x_per_s, kv_y_per_s
        Position-loop gains of the X and Y axes, 1/s.
    sync_lag_um_per_m_s2, gantry_span_mm, tool_offset_mm
        Lag between the two X drives per m/s² of acceleration (μm), the distance between them,
        and the tool's distance from the beam axis (mm).
    ripple_amplitude_um, ripple_period_mm, ripple_phase_rad
        Force-ripple amplitude (μm), its wavelength along the path (mm) and phase.
    motor_rise_K, motor_tau_min, motor_warm_min, bow_um_per_K, ambient_C, motor_noise_C
        Final motor temperature rise, its time constant, minutes of operation before the
        record starts, guideway bow at mid stroke per kelvin, room temperature, and the
        motor-sensor noise.
    laser_noise_um
        Standard deviation of the interferometer's deviation reading, μm.
    """

    guideway_straightness: float = 1.0
    sync_error: float = 1.0
    servo_lag: float = 1.0
    ripple: float = 1.0
    motor_heating: float = 1.0
    measurement_noise: float = 1.0
    stroke_x_mm: float = 150.0
    stroke_y_mm: float = 4.0
    feed_mm_min: float = 400.0
    acceleration_mm_s2: float = 20.0
    dwell_s: float = 1.0
    sample_hz: float = 15.0
    straightness_um: float = 9.0
    shape_seed: int = 4
    kv_x_per_s: float = 30.0
    kv_y_per_s: float = 20.0
    sync_lag_um_per_m_s2: float = 400.0
    gantry_span_mm: float = 800.0
    tool_offset_mm: float = 300.0
    ripple_amplitude_um: float = 1.0
    ripple_period_mm: float = 1.5
    ripple_phase_rad: float = 0.3
    motor_rise_K: float = 8.0
    motor_tau_min: float = 20.0
    motor_warm_min: float = 30.0
    bow_um_per_K: float = 0.4
    ambient_C: float = 20.0
    motor_noise_C: float = 0.02
    laser_noise_um: float = 0.15

    def __post_init__(self) -> None:
        for name in (*EFFECTS, "measurement_noise"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ProblemError(f"{name}: effect scale must be finite and >= 0, got {value}")
        positive = ("stroke_x_mm", "feed_mm_min", "acceleration_mm_s2", "sample_hz", "kv_x_per_s",
                    "kv_y_per_s", "gantry_span_mm", "ripple_period_mm", "motor_tau_min")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ProblemError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.dwell_s < 0 or self.laser_noise_um < 0 or self.motor_noise_C < 0:
            raise ProblemError("dwell_s, laser_noise_um and motor_noise_C must be >= 0")


def path_profile(config: GantryConfig,
                 t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Commanded path length (mm), speed (mm/s) and acceleration (mm/s²) at times ``t_s``.

    A trapezoidal (or, for short strokes, triangular) speed profile starting after the dwell.
    """
    length = np.hypot(config.stroke_x_mm, config.stroke_y_mm)
    a = config.acceleration_mm_s2
    v = min(config.feed_mm_min / 60.0, np.sqrt(a * length))
    t_acc = v / a
    t_move = length / v + t_acc
    t = np.clip(np.asarray(t_s, dtype=float) - config.dwell_s, 0.0, t_move)
    accelerating, decelerating = t < t_acc, t > t_move - t_acc
    t_end = t_move - t  # time left to the end of the move
    s = np.where(accelerating, 0.5 * a * t**2,
                 np.where(decelerating, length - 0.5 * a * t_end**2, v * (t - 0.5 * t_acc)))
    speed = np.where(accelerating, a * t, np.where(decelerating, a * t_end, v))
    acceleration = np.where(accelerating, a, np.where(decelerating, -a, 0.0))
    moving = (np.asarray(t_s) > config.dwell_s) & (np.asarray(t_s) < config.dwell_s + t_move)
    return s, speed, np.where(moving, acceleration, 0.0)


def record_duration_s(config: GantryConfig) -> float:
    """Length of the record: dwell, the move, dwell."""
    length = np.hypot(config.stroke_x_mm, config.stroke_y_mm)
    v = min(config.feed_mm_min / 60.0, np.sqrt(config.acceleration_mm_s2 * length))
    return 2 * config.dwell_s + length / v + v / config.acceleration_mm_s2


def _following_error_mm(speed_mm_s: np.ndarray, kv_per_s: float) -> np.ndarray:
    """Lag of a proportional position loop, :math:`\\dot e = v - K_v e`, on the fine grid.

    It is the speed through a first-order lag of time constant :math:`1/K_v`, divided by
    :math:`K_v`.
    """
    return first_order_lag(speed_mm_s, SERVO_STEP_S, 1 / kv_per_s) / kv_per_s


def simulate_gantry(config: GantryConfig | None = None, seed: int = 0) -> pd.DataFrame:
    """Simulate the interferometer record of a linear interpolation.

    Parameters
    ----------
    config
        The gantry and which effects are on; default :class:`GantryConfig` (S4 set-up).
    seed
        Seed of the laser and motor-sensor noise (drawn the same way whatever the scales).

    Returns
    -------
    pandas.DataFrame
        ``time_s, x_mm, y_mm, deviation_um, feed_mm_min, accel_mm_s2, motor_C``, one
        ``effect_<name>_um`` per effect in :data:`EFFECTS`, and ``noise_um``;
        ``deviation_um`` equals the sum of the effect columns and ``noise_um``.
    """
    config = GantryConfig() if config is None else config
    rng = np.random.default_rng(seed)
    phi = np.arctan2(config.stroke_y_mm, config.stroke_x_mm)
    direction, normal = np.array([np.cos(phi), np.sin(phi)]), np.array([-np.sin(phi), np.cos(phi)])
    t_s = np.arange(0.0, record_duration_s(config) + 1e-9, 1.0 / config.sample_hz)

    # Position loops on a fine grid, sampled at the interferometer's time base.
    t_fine = np.arange(0.0, t_s[-1] + SERVO_STEP_S, SERVO_STEP_S)
    _, speed_fine, accel_fine = path_profile(config, t_fine)
    lag_x = _following_error_mm(speed_fine * direction[0], config.kv_x_per_s)
    lag_y = _following_error_mm(speed_fine * direction[1], config.kv_y_per_s)
    seen_accel = first_order_lag(accel_fine * direction[0], SERVO_STEP_S, 1 / config.kv_x_per_s)
    sample = np.minimum(np.rint(t_s / SERVO_STEP_S).astype(int), t_fine.size - 1)
    following_mm = -np.column_stack([lag_x[sample], lag_y[sample]])  # actual − commanded

    s_mm, speed, accel = path_profile(config, t_s)
    x_cmd = s_mm * direction[0]
    u = x_cmd / config.stroke_x_mm
    motor_rise_K = config.motor_rise_K * (
        1 - np.exp(-(t_s / 60.0 + config.motor_warm_min) / config.motor_tau_min)
    )
    effects = {
        "guideway_straightness": config.straightness_um * smooth_shape(u, config.shape_seed),
        "sync_error": config.sync_lag_um_per_m_s2 * (seen_accel[sample] / 1000.0)
        * config.tool_offset_mm / config.gantry_span_mm,
        "servo_lag": 1e3 * following_mm @ normal,
        "ripple": config.ripple_amplitude_um
        * np.sin(2 * np.pi * s_mm / config.ripple_period_mm + config.ripple_phase_rad),
        "motor_heating": config.bow_um_per_K * motor_rise_K * 4 * u * (1 - u),
    }
    effects = {name: getattr(config, name) * values for name, values in effects.items()}
    noise_um = rng.standard_normal(t_s.size) * config.laser_noise_um * config.measurement_noise
    motor_noise = rng.standard_normal(t_s.size) * config.motor_noise_C
    deviation_um = sum(effects.values()) + noise_um

    # Actual position: along-path lag (no normal component) plus the normal deviation.
    along_mm = (following_mm @ direction)[:, None] * direction
    actual = s_mm[:, None] * direction + along_mm + 1e-3 * deviation_um[:, None] * normal
    table = {
        "time_s": t_s,
        "x_mm": actual[:, 0],
        "y_mm": actual[:, 1],
        "deviation_um": deviation_um,
        "feed_mm_min": 60.0 * speed,
        "accel_mm_s2": accel,
        "motor_C": config.ambient_C + config.motor_heating * motor_rise_K + motor_noise,
    }
    table.update({f"effect_{name}_um": values for name, values in effects.items()})
    table["noise_um"] = noise_um
    return pd.DataFrame(table)
