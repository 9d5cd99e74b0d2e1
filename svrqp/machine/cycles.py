"""Operating cycles: piecewise-constant spindle speed and feed-axis duty over time.

A cycle is a tuple of :class:`CycleSegment` run one after the other from ``t = 0``; before
``t = 0`` (while the machine soaks) and after the last segment the machine stands still.
The helpers build the programmes used in thermal tests: speed steps, run/stop cycles and an
ISO 230-3-like warm-up followed by a cool-down.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from svrqp.exceptions import ProblemError


@dataclass(frozen=True)
class CycleSegment:
    """One stretch of constant operation.

    Parameters
    ----------
    duration_min
        Length of the segment, minutes (> 0).
    speed_rpm
        Spindle speed, rev/min (>= 0; 0 means the spindle stands still).
    axis_duty_pct
        Share of the time the feed axis moves, percent (0–100); it drives ball-screw nut heating.
    """

    duration_min: float
    speed_rpm: float = 0.0
    axis_duty_pct: float = 0.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.duration_min) and self.duration_min > 0):
            raise ProblemError(f"duration_min must be > 0, got {self.duration_min}")
        if not (np.isfinite(self.speed_rpm) and self.speed_rpm >= 0):
            raise ProblemError(f"speed_rpm must be >= 0, got {self.speed_rpm}")
        if not (0.0 <= self.axis_duty_pct <= 100.0):
            raise ProblemError(f"axis_duty_pct must lie in [0, 100], got {self.axis_duty_pct}")


def duration_min(cycle: Sequence[CycleSegment]) -> float:
    """Total length of a cycle, minutes."""
    return float(sum(segment.duration_min for segment in cycle))


def operation_at(cycle: Sequence[CycleSegment], t_min: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed (rpm) and axis duty (%) in force at each time; zero outside the cycle.

    Segments are closed on the left: at a boundary the new segment's values apply.
    """
    if not cycle:
        raise ProblemError("cycle: at least one segment is required")
    t_min = np.asarray(t_min, dtype=float)
    ends = np.cumsum([segment.duration_min for segment in cycle])
    index = np.searchsorted(ends, t_min, side="right")
    inside = (t_min >= 0) & (index < len(cycle))
    speeds = np.array([segment.speed_rpm for segment in cycle] + [0.0])
    duties = np.array([segment.axis_duty_pct for segment in cycle] + [0.0])
    index = np.where(inside, index, len(cycle))
    return speeds[index], duties[index]


def warm_up_cool_down(
    speed_rpm: float, warm_min: float = 240.0, cool_min: float = 60.0, axis_duty_pct: float = 0.0
) -> tuple[CycleSegment, ...]:
    """ISO 230-3-like test: run at constant speed for ``warm_min``, then stop for ``cool_min``."""
    return (CycleSegment(warm_min, speed_rpm, axis_duty_pct), CycleSegment(cool_min, 0.0, 0.0))


def speed_steps(
    speeds_rpm: Sequence[float], minutes_each: float, axis_duty_pct: float = 0.0
) -> tuple[CycleSegment, ...]:
    """Consecutive constant-speed steps of equal length."""
    return tuple(CycleSegment(minutes_each, s, axis_duty_pct) for s in speeds_rpm)


def run_stop(
    speed_rpm: float, run_min: float, stop_min: float, repeats: int, axis_duty_pct: float = 0.0
) -> tuple[CycleSegment, ...]:
    """``repeats`` run/stop pairs (e.g. machining a workpiece, then loading the next)."""
    if repeats < 1:
        raise ProblemError(f"repeats must be >= 1, got {repeats}")
    pair = (CycleSegment(run_min, speed_rpm, axis_duty_pct), CycleSegment(stop_min, 0.0, 0.0))
    return pair * repeats
