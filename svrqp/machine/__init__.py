"""A machine-tool simulator whose physical effects can be switched on and off one by one.

* :mod:`svrqp.machine.thermal` — thermal drift of a machining centre from a lumped-capacitance
  network (:mod:`svrqp.machine.network`) under an operating cycle (:mod:`svrqp.machine.cycles`).
* :mod:`svrqp.machine.geometry` — the six error components of a linear axis and a
  laser-interferometer nine-line measurement of them.
* :mod:`svrqp.machine.contour` — straightness deviation of a 2X/Y gantry during a linear
  interpolation, recorded at a 15 Hz time base.
* :mod:`svrqp.datasets.build` — regenerates the embedded datasets (``svrqp.datasets``).

Every simulator takes one frozen config dataclass in which each physical effect is a named
scale (0 turns it off) and returns a table with one ``effect_<name>_um`` column per effect,
so that the target equals the sum of the effect columns plus ``noise_um``.
"""

from svrqp.machine.contour import EFFECTS as GANTRY_EFFECTS, GantryConfig, simulate_gantry
from svrqp.machine.geometry import (
    EFFECTS as AXIS_EFFECTS,
    AxisConfig,
    measure_nine_line,
    simulate_axis,
    true_components,
)
from svrqp.machine.thermal import EFFECTS as THERMAL_EFFECTS, ThermalConfig, simulate_thermal

__all__ = [
    "AXIS_EFFECTS", "GANTRY_EFFECTS", "THERMAL_EFFECTS", "AxisConfig", "GantryConfig",
    "ThermalConfig", "measure_nine_line", "simulate_axis", "simulate_gantry", "simulate_thermal",
    "true_components",
]
