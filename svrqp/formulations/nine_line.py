r"""Nine-line identification of the six error components of a linear axis (S2 eqs. (1)–(6)).

A rigid carriage moving along X has, at each position :math:`x`, three translational errors
:math:`\delta_x, \delta_y, \delta_z` (positioning, two straightnesses; μm) and three rotations
:math:`\theta_x, \theta_y, \theta_z` (roll, pitch, yaw; μrad). A laser interferometer along
line :math:`k` watches the point :math:`P_k` whose offset from the carriage reference point is
:math:`(x_k, y_k, z_k)` mm. Small-angle rigid-body kinematics (S2 eqs. (1)–(2)), with the
factor :math:`10^{-3}` turning mm·μrad into μm:

.. math::

    \Delta x_k &= \delta_x - 10^{-3} y_k \theta_z + 10^{-3} z_k \theta_y \\
    \Delta y_k &= \delta_y + 10^{-3} x_k \theta_z - 10^{-3} z_k \theta_x \\
    \Delta z_k &= \delta_z - 10^{-3} x_k \theta_y + 10^{-3} y_k \theta_x

Stacking the measured readings gives :math:`\Delta = A\,\varepsilon` (S2 eqs. (3)–(4)) with
:math:`\varepsilon = (\delta_x, \delta_y, \delta_z, \theta_x, \theta_y, \theta_z)^\top`; each
row of :math:`A` (built by :func:`nine_line_matrix`) is one of

.. math::

    \Delta x_k &: (1, 0, 0, 0, 10^{-3} z_k, -10^{-3} y_k) \\
    \Delta y_k &: (0, 1, 0, -10^{-3} z_k, 0, 10^{-3} x_k) \\
    \Delta z_k &: (0, 0, 1, 10^{-3} y_k, -10^{-3} x_k, 0)

**Original method** (S2 eq. (1)): :math:`\Delta x_{1,2,3}, \Delta y_{1,2}, \Delta z_1` — six
equations, six unknowns, :math:`A\varepsilon = \Delta` solved directly. :math:`A` is singular
when the three points are collinear in the :math:`(y, z)` plane (the :math:`\Delta x` rows cannot
separate :math:`\delta_x, \theta_y, \theta_z`) or when lines 1 and 2 share :math:`z` (the
:math:`\Delta y` rows cannot separate :math:`\delta_y` from :math:`\theta_x`). Errors in
:math:`\delta_x, \theta_y, \theta_z` propagate into the others.

**Improved method** (S2 eqs. (2)–(6)): all three readings on all three lines, nine equations,
solved in the least-squares sense by the normal equations

.. math::

    A^\top A\, \varepsilon = A^\top \Delta
    \quad\Longrightarrow\quad
    \varepsilon = (A^\top A)^{-1} A^\top \Delta .

With independent reading noise of standard deviation :math:`\sigma`, the component errors have
covariances :math:`\sigma^2 A^{-1}A^{-\top}` (original) and :math:`\sigma^2 (A^\top A)^{-1}`
(improved). For the layout :data:`EXAMPLE_OFFSETS_MM`, :math:`P_1 = (0, 0, 200)`,
:math:`P_2 = (100, 0, 0)`, :math:`P_3 = (-100, 200, 0)` mm, the standard deviations of the
original method are larger by a factor of 1.25 (:math:`\delta_x`), 1.86 (:math:`\delta_y`), 1.52
(:math:`\delta_z`), 1.66 (:math:`\theta_x`), 1.33 (:math:`\theta_y`) and 1.45
(:math:`\theta_z`) — about 1.5× on average; ``tests/test_nine_line.py`` confirms the factors by
Monte Carlo. The gain depends on the layout: with all :math:`x_k = 0` the extra Δy, Δz readings
carry no information on :math:`\theta_y, \theta_z` and those two (and :math:`\delta_x`) do not
improve at all.

This module identifies the X axis; the Y and Z axes follow from the same equations with the
coordinates permuted cyclically.

Measurement table (the format the machine simulator writes): one row per (position, line),
columns ``x_mm, line, x_off_mm, y_off_mm, z_off_mm, dx_um, dy_um, dz_um``; NaN where a
quantity was not measured.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError, SingularSystemError
from svrqp.formulations.least_squares import (
    CONDITION_WARNING,
    IllConditionedWarning,
    solve_normal_equations,
)

#: The six error components, in the order of :math:`\varepsilon`.
COMPONENTS = (
    "delta_x_um", "delta_y_um", "delta_z_um", "theta_x_urad", "theta_y_urad", "theta_z_urad",
)
#: Reading columns, in the order of the quantities in a measured mask.
READINGS = ("dx_um", "dy_um", "dz_um")
OFFSETS = ("x_off_mm", "y_off_mm", "z_off_mm")
LINES = (1, 2, 3)

#: Original method (S2 eq. (1)): Δx on lines 1–3, Δy on lines 1–2, Δz on line 1.
ORIGINAL_SET = np.array([[True, True, True], [True, True, False], [True, False, False]])
#: Improved method (S2 eq. (2)): all three readings on all three lines.
IMPROVED_SET = np.ones((3, 3), dtype=bool)

#: One arcsecond in microradians: π / (180 · 3600) · 10⁶.
URAD_PER_ARCSEC = np.pi / 648000.0 * 1e6
MM_URAD_TO_UM = 1e-3

#: A well-conditioned layout (mm; rows: lines 1–3; columns: x, y, z offsets) used in examples.
EXAMPLE_OFFSETS_MM = np.array([[0.0, 0.0, 200.0], [100.0, 0.0, 0.0], [-100.0, 200.0, 0.0]])


def urad_to_arcsec(angle_urad: np.ndarray | float) -> np.ndarray | float:
    """Convert an angle from μrad to arcseconds."""
    return angle_urad / URAD_PER_ARCSEC


def arcsec_to_urad(angle_arcsec: np.ndarray | float) -> np.ndarray | float:
    """Convert an angle from arcseconds to μrad."""
    return angle_arcsec * URAD_PER_ARCSEC


def _check_offsets(offsets_mm: np.ndarray) -> np.ndarray:
    offsets_mm = np.asarray(offsets_mm, dtype=float)
    if offsets_mm.shape != (3, 3):
        raise ProblemError(
            f"offsets must be a 3×3 array (lines 1–3 × x, y, z offsets in mm), "
            f"got shape {offsets_mm.shape}"
        )
    if not np.isfinite(offsets_mm).all():
        raise ProblemError("offsets contain NaN or inf")
    return offsets_mm


def nine_line_matrix(offsets_mm: np.ndarray, measured_mask: np.ndarray) -> np.ndarray:
    """The matrix :math:`A` of :math:`\\Delta = A\\varepsilon` (S2 eqs. (1), (3)–(4)).

    Parameters
    ----------
    offsets_mm : array of shape (3, 3)
        Row :math:`k` is :math:`(x_k, y_k, z_k)` of line :math:`k+1`, in mm.
    measured_mask : bool array of shape (3, 3)
        ``measured_mask[k, q]``: reading ``q`` (Δx, Δy, Δz) is measured on line :math:`k+1`.

    Returns
    -------
    ndarray of shape (m, 6)
        One row per measured reading, ordered by line, then Δx, Δy, Δz; columns in the order
        of :data:`COMPONENTS`.
    """
    offsets_mm = _check_offsets(offsets_mm)
    measured_mask = np.asarray(measured_mask, dtype=bool)
    if measured_mask.shape != (3, 3):
        raise ProblemError(f"measured_mask must be 3×3, got shape {measured_mask.shape}")
    rows = []
    for (x_k, y_k, z_k), measured in zip(offsets_mm * MM_URAD_TO_UM, measured_mask, strict=True):
        line_rows = np.array([
            [1.0, 0.0, 0.0, 0.0, z_k, -y_k],  # Δx_k
            [0.0, 1.0, 0.0, -z_k, 0.0, x_k],  # Δy_k
            [0.0, 0.0, 1.0, y_k, -x_k, 0.0],  # Δz_k
        ])
        rows.append(line_rows[measured])
    return np.vstack(rows)


def simulate_readings(
    components: pd.DataFrame, offsets_mm: np.ndarray, measured_mask: np.ndarray = IMPROVED_SET
) -> pd.DataFrame:
    """Noise-free interferometer readings from known error components (the forward model).

    Parameters
    ----------
    components : DataFrame
        Columns ``x_mm`` and the six :data:`COMPONENTS`, one row per position.
    offsets_mm : array of shape (3, 3)
        Measuring-point offsets of lines 1–3 (mm).
    measured_mask : bool array of shape (3, 3)
        Readings that are measured; the others are NaN.

    Returns
    -------
    DataFrame
        The long measurement table described in the module docstring.
    """
    offsets_mm = _check_offsets(offsets_mm)
    missing = [c for c in ("x_mm", *COMPONENTS) if c not in components.columns]
    if missing:
        raise ProblemError(f"components: missing column(s) {missing}")
    epsilon = components[list(COMPONENTS)].to_numpy(dtype=float)
    A = nine_line_matrix(offsets_mm, IMPROVED_SET)  # 9 × 6, rows line-major
    readings = (epsilon @ A.T).reshape(len(components), 3, 3)
    readings[:, ~np.asarray(measured_mask, dtype=bool)] = np.nan
    n = len(components)
    table = pd.DataFrame({
        "x_mm": np.repeat(components["x_mm"].to_numpy(dtype=float), 3),
        "line": np.tile(LINES, n),
    })
    for j, name in enumerate(OFFSETS):
        table[name] = np.tile(offsets_mm[:, j], n)
    for q, name in enumerate(READINGS):
        table[name] = readings[:, :, q].reshape(-1)
    return table


def _positions(measurements: pd.DataFrame) -> Iterator[tuple[float, np.ndarray, np.ndarray]]:
    """Yield ``(x_mm, offsets (3, 3), readings (3, 3))`` for each position, lines in order."""
    required = ("x_mm", "line", *OFFSETS, *READINGS)
    missing = [c for c in required if c not in measurements.columns]
    if missing:
        raise ProblemError(f"measurements: missing column(s) {missing}")
    if measurements.empty:
        raise ProblemError("measurements: the table is empty")
    unknown = sorted(set(measurements["line"]) - set(LINES))
    if unknown:
        raise ProblemError(f"measurements: line must be 1, 2 or 3, found {unknown}")
    if measurements[["x_mm", *OFFSETS]].isna().any().any():
        raise ProblemError("measurements: x_mm and the offsets must not be NaN")
    table = measurements.sort_values(["x_mm", "line"], kind="stable")
    x_mm = table["x_mm"].to_numpy(dtype=float)
    lines = table["line"].to_numpy()
    offsets = table[list(OFFSETS)].to_numpy(dtype=float)
    readings = table[list(READINGS)].to_numpy(dtype=float)
    starts = np.flatnonzero(np.r_[True, x_mm[1:] != x_mm[:-1]])
    for start, stop in zip(starts, np.r_[starts[1:], len(x_mm)], strict=True):
        if list(lines[start:stop]) != list(LINES):
            raise ProblemError(
                f"measurements at x_mm={x_mm[start]}: need exactly one row per line 1, 2, 3, "
                f"got {list(lines[start:stop])}"
            )
        yield float(x_mm[start]), offsets[start:stop], readings[start:stop]


def _require_measured(x_mm: float, readings: np.ndarray, mask: np.ndarray, method: str) -> None:
    absent = mask & np.isnan(readings)
    if absent.any():
        names = [f"{READINGS[q]} on line {k + 1}" for k, q in np.argwhere(absent)]
        raise ProblemError(
            f"{method} nine-line method at x_mm={x_mm}: reading(s) not measured (NaN): {names}"
        )
    if not np.isfinite(readings[mask]).all():
        raise ProblemError(f"{method} nine-line method at x_mm={x_mm}: non-finite reading")


def _singular_geometry_reasons(offsets_mm: np.ndarray) -> list[str]:
    y, z = offsets_mm[:, 1], offsets_mm[:, 2]
    reasons = []
    if np.isclose(np.linalg.det(np.column_stack([np.ones(3), y, z])), 0.0, atol=1e-9):
        reasons.append("the points of lines 1–3 are collinear in the (y, z) plane, so the Δx "
                       "readings cannot separate δx, θy and θz")
    if np.isclose(z[0], z[1]):
        reasons.append("lines 1 and 2 share z, so the Δy readings cannot separate δy and θx")
    return reasons


def _solve_original(x_mm: float, offsets_mm: np.ndarray, readings: np.ndarray) -> np.ndarray:
    A = nine_line_matrix(offsets_mm, ORIGINAL_SET)
    singular_values = np.linalg.svd(A, compute_uv=False)
    if singular_values[-1] <= 6 * np.finfo(float).eps * singular_values[0]:
        reasons = _singular_geometry_reasons(offsets_mm) or ["the 6×6 matrix is rank deficient"]
        raise SingularSystemError(
            f"original nine-line system is singular at x_mm={x_mm}: " + "; ".join(reasons)
        )
    # Compared squared, like the normal equations' threshold, so both methods warn alike.
    condition_number = float(singular_values[0] / singular_values[-1])
    if condition_number**2 > CONDITION_WARNING:
        warnings.warn(
            f"original nine-line system at x_mm={x_mm} is ill conditioned (condition number "
            f"{condition_number:.2e}); the measuring points are nearly degenerate",
            IllConditionedWarning,
            stacklevel=4,
        )
    return np.linalg.solve(A, readings[ORIGINAL_SET])


def _solve_improved(offsets_mm: np.ndarray, readings: np.ndarray) -> np.ndarray:
    A = nine_line_matrix(offsets_mm, IMPROVED_SET)
    return solve_normal_equations(A, readings[IMPROVED_SET], column_names=COMPONENTS).coef


def _identify(measurements: pd.DataFrame, method: str) -> pd.DataFrame:
    mask = ORIGINAL_SET if method == "original" else IMPROVED_SET
    rows = []
    for x_mm, offsets_mm, readings in _positions(measurements):
        _require_measured(x_mm, readings, mask, method)
        if method == "original":
            epsilon = _solve_original(x_mm, offsets_mm, readings)
        else:
            epsilon = _solve_improved(offsets_mm, readings)
        rows.append([x_mm, *epsilon])
    return pd.DataFrame(rows, columns=["x_mm", *COMPONENTS])


def identify_original(measurements: pd.DataFrame) -> pd.DataFrame:
    """Six error components per position by the original nine-line method (6×6 solve).

    Parameters
    ----------
    measurements : DataFrame
        The long measurement table; only Δx on lines 1–3, Δy on lines 1–2 and Δz on line 1
        are used (others may be present or NaN).

    Returns
    -------
    DataFrame
        Columns ``x_mm`` and :data:`COMPONENTS` (μm and μrad), one row per position.

    Raises
    ------
    ProblemError
        Missing columns or lines, a needed reading is NaN.
    SingularSystemError
        The measuring points make the 6×6 system singular; the message says why.
    """
    return _identify(measurements, "original")


def identify_improved(measurements: pd.DataFrame) -> pd.DataFrame:
    """Six error components per position by the improved method (S2 eqs. (3)–(6)).

    Solves the nine-reading overdetermined system :math:`\\Delta = A\\varepsilon` by the normal
    equations :math:`A^\\top A\\varepsilon = A^\\top\\Delta`. Same parameters, return value and
    errors as :func:`identify_original`, with all nine readings required.
    """
    return _identify(measurements, "improved")
