r"""Compensation strategies of the source papers, and the residual metrics they report.

Sign convention: a *deviation* :math:`e` is what the machine should remove (S4 eq. (3):
reference line minus actual position). A compensation output :math:`\Delta` is superimposed on
the axis command, so the remaining deviation is :math:`r = e - \Delta`.

Windowed-mean feed-forward output with a dead band (S4 eq. (8))
---------------------------------------------------------------
In output period :math:`j` the axis passes :math:`x_0 \dots x_T`; with the feed-forward offset
:math:`x_f` (S4: 10 mm, taken in the direction of motion) and the model's predicted deviation
:math:`\hat e(x)`,

.. math::

    E_j = \frac{1}{\lvert x_T + x_f - x_0 \rvert} \int_{x_0}^{x_T + x_f} \hat e(x)\,dx,
    \qquad
    \Delta_j = \begin{cases} E_j & \lvert E_j \rvert \ge d \\ 0 & \lvert E_j \rvert < d \end{cases}

with the dead band :math:`d = 1` μm. :func:`windowed_mean_offsets` evaluates the integral by
the trapezoidal rule on a fine grid and holds :math:`\Delta_j` for every sample of period
:math:`j`. :math:`E_j` is the mean of :math:`\hat e` over the window; for motion towards
:math:`-x` the window ends at :math:`x_T - x_f` and the integral and the length are both taken
with their sign, so the mean keeps its sign.

On-line recursive loop (S3)
---------------------------
For each new sample (or workpiece batch) :math:`k`: predict :math:`\hat y_k = x_k^\top a_{k-1}`
with the current model, compensate (residual :math:`y_k - \hat y_k`), then update the model
with the measured :math:`y_k` (S3 eqs. (13)–(17)); :func:`online_compensation`.

Residual metrics
----------------
For residuals :math:`r_1 \dots r_n`: RMS :math:`\sqrt{\tfrac1n\sum r_i^2}` (S0's table: S0 calls it
the "standard deviation" :math:`s` but computes the root mean square of the residuals, §4.3),
the standard deviation proper :math:`\sqrt{\tfrac1n\sum (r_i - \bar r)^2}` (the RMS with the mean
removed, i.e. what a per-run offset recalibration would leave), max :math:`\lvert r \rvert` and mean
:math:`\lvert r \rvert` (S3's table), peak-to-peak :math:`\max r - \min r` (S4's straightness),
and the improvement :math:`100\,(1 - m_\text{after}/m_\text{before})` % of a metric :math:`m`.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any, Protocol

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError
from svrqp.formulations.least_squares import check_finite_matrix
from svrqp.metrics import rms


@dataclass(frozen=True)
class ResidualMetrics:
    """Residual statistics (μm) as the papers report them.

    ``rms_um`` is S0's "standard deviation" (the root mean square of the residuals); ``std_um``
    removes the mean first and is never what S0 tabulates.
    """

    rms_um: float
    std_um: float
    max_abs_um: float
    mean_abs_um: float
    peak_to_peak_um: float

    def as_dict(self) -> dict[str, float]:
        """The metrics as a plain dictionary (for tables and JSON)."""
        return asdict(self)


def residual_metrics(residual_um: np.ndarray) -> ResidualMetrics:
    """RMS, standard deviation, max |r|, mean |r| and peak-to-peak of ``residual_um``."""
    r = check_finite_matrix(residual_um, "residual_um", 1)
    if r.size == 0:
        raise ProblemError("residual_um is empty")
    return ResidualMetrics(
        rms_um=float(rms(r)),
        std_um=float(np.std(r)),
        max_abs_um=float(np.max(np.abs(r))),
        mean_abs_um=float(np.mean(np.abs(r))),
        peak_to_peak_um=float(np.ptp(r)),
    )


def improvement_percent(before: float, after: float) -> float:
    """Percentage improvement :math:`100 (1 - \\text{after}/\\text{before})` of a metric."""
    if not (np.isfinite(before) and np.isfinite(after)) or before <= 0:
        raise ProblemError(
            f"improvement needs a positive finite 'before' metric, got before={before}, "
            f"after={after}"
        )
    return 100.0 * (1.0 - after / before)


@dataclass(frozen=True)
class CompensatedRun:
    """A recorded run with a compensation applied.

    Attributes
    ----------
    deviation_um : ndarray
        Recorded deviation :math:`e`.
    offset_um : ndarray
        Compensation output :math:`\\Delta` held at each sample.
    residual_um : ndarray
        :math:`e - \\Delta`.
    before, after : ResidualMetrics
        Metrics of ``deviation_um`` and of ``residual_um``.
    """

    deviation_um: np.ndarray
    offset_um: np.ndarray
    residual_um: np.ndarray
    before: ResidualMetrics
    after: ResidualMetrics

    @property
    def improvement_percent(self) -> float:
        """Improvement of the peak-to-peak deviation (S4's straightness), in %."""
        return improvement_percent(self.before.peak_to_peak_um, self.after.peak_to_peak_um)


def _compensated(deviation_um: np.ndarray, offset_um: np.ndarray) -> CompensatedRun:
    residual_um = deviation_um - offset_um
    return CompensatedRun(deviation_um, offset_um, residual_um,
                          residual_metrics(deviation_um), residual_metrics(residual_um))


def windowed_mean_offsets(
    x_mm: np.ndarray,
    predict_um: Callable[[np.ndarray], np.ndarray],
    *,
    samples_per_period: int,
    feed_forward_mm: float = 10.0,
    dead_band_um: float = 1.0,
    grid_points: int = 64,
) -> np.ndarray:
    """Compensation output of S4 eq. (8) held at each sample of a run.

    Parameters
    ----------
    x_mm : array of shape (n,)
        Axis positions in time order, one per sample of the run (moving one way).
    predict_um : callable
        Predicted deviation :math:`\\hat e(x)` (μm) at an array of positions (mm), e.g.
        ``lambda x: model.predict(x[:, None])``.
    samples_per_period : int
        Samples in one compensation output period (S4: the 10 ms control cycle over the
        15 Hz sampling of the run).
    feed_forward_mm : float
        :math:`x_f \\ge 0`, the look-ahead in the direction of motion (S4: 10 mm).
    dead_band_um : float
        :math:`d \\ge 0`: outputs with :math:`|E| < d` are suppressed (S4: 1 μm).
    grid_points : int
        Trapezoidal-rule points per window.

    Returns
    -------
    ndarray of shape (n,)
        :math:`\\Delta_j` repeated over the samples of period :math:`j`.
    """
    x_mm = check_finite_matrix(x_mm, "x_mm", 1)
    if x_mm.size < 2:
        raise ProblemError("a run needs at least 2 positions")
    if not isinstance(samples_per_period, (int, np.integer)) or samples_per_period < 1:
        raise ProblemError(f"samples_per_period must be a positive integer, got "
                           f"{samples_per_period!r}")
    if grid_points < 2:
        raise ProblemError(f"grid_points must be at least 2, got {grid_points}")
    if not (feed_forward_mm >= 0 and dead_band_um >= 0):
        raise ProblemError(
            f"feed_forward_mm and dead_band_um must be >= 0, got {feed_forward_mm}, {dead_band_um}"
        )
    direction = np.sign(x_mm[-1] - x_mm[0])
    if direction == 0 or np.any(np.diff(x_mm) * direction < 0):
        raise ProblemError("x_mm must move one way (monotone, not stationary) over the run")
    offsets = np.empty_like(x_mm)
    for start in range(0, x_mm.size, samples_per_period):
        period = slice(start, start + samples_per_period)
        x_0, x_T = x_mm[period][0], x_mm[period][-1]
        window = np.linspace(x_0, x_T + direction * feed_forward_mm, grid_points)
        e_hat = np.asarray(predict_um(window), dtype=float).reshape(-1)
        if e_hat.shape != window.shape or not np.isfinite(e_hat).all():
            raise ProblemError(
                f"predict_um must return {window.size} finite values for {window.size} "
                f"positions, got shape {e_hat.shape}"
            )
        length = abs(window[-1] - window[0])
        E = np.trapezoid(e_hat, window) / (window[-1] - window[0]) if length > 0 else e_hat[0]
        offsets[period] = E if abs(E) >= dead_band_um else 0.0
    return offsets


def compensate_recorded_run(
    x_mm: np.ndarray,
    deviation_um: np.ndarray,
    predict_um: Callable[[np.ndarray], np.ndarray],
    *,
    samples_per_period: int,
    feed_forward_mm: float = 10.0,
    dead_band_um: float = 1.0,
) -> CompensatedRun:
    """Apply the S4 eq. (8) output to a recorded run and measure what remains.

    Parameters are those of :func:`windowed_mean_offsets`, plus ``deviation_um`` (shape (n,)),
    the recorded deviation at each position.
    """
    deviation_um = check_finite_matrix(deviation_um, "deviation_um", 1)
    x_mm = check_finite_matrix(x_mm, "x_mm", 1)
    if deviation_um.shape != x_mm.shape:
        raise ProblemError(
            f"x_mm and deviation_um differ in length: {x_mm.size} vs {deviation_um.size}"
        )
    offsets = windowed_mean_offsets(x_mm, predict_um, samples_per_period=samples_per_period,
                                    feed_forward_mm=feed_forward_mm, dead_band_um=dead_band_um)
    return _compensated(deviation_um, offsets)


class OnlineModel(Protocol):
    """A fitted regressor that can be updated: e.g. :class:`svrqp.estimators.linear.RecursiveLS`."""

    def predict(self, X: Any) -> np.ndarray: ...

    def partial_fit(self, X: Any, y: Any) -> Any: ...


@dataclass(frozen=True)
class OnlineRun:
    """Result of the S3 on-line loop.

    Attributes
    ----------
    run : CompensatedRun
        ``deviation_um`` is the measured error, ``offset_um`` the prediction made *before* each
        sample was seen, ``residual_um`` their difference.
    model : OnlineModel
        The model after the last update (a copy; the caller's model is left unchanged).
    """

    run: CompensatedRun
    model: OnlineModel


def online_compensation(
    model: OnlineModel, X: np.ndarray | pd.DataFrame, y_um: np.ndarray | pd.Series, *,
    batch_size: int = 1,
) -> OnlineRun:
    """Run S3's on-line loop: predict, compensate, then update the model with the measurement.

    Parameters
    ----------
    model : OnlineModel
        A fitted model with ``predict`` and ``partial_fit`` (it is copied, not modified).
    X : array-like of shape (n, n_features)
        Inputs in time order (e.g. temperatures).
    y_um : array-like of shape (n,)
        Measured errors (μm).
    batch_size : int
        Samples predicted with the same model before it is updated (S3: one workpiece).
    """
    if not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
        raise ProblemError(f"batch_size must be a positive integer, got {batch_size!r}")
    y_values = check_finite_matrix(np.asarray(y_um, dtype=float), "y_um", 1)
    if len(X) != y_values.size:
        raise ProblemError(f"X has {len(X)} rows but y_um has {y_values.size} values")
    model = copy.deepcopy(model)
    predicted = np.empty_like(y_values)
    for start in range(0, y_values.size, batch_size):
        rows = slice(start, start + batch_size)
        X_rows = X.iloc[rows] if isinstance(X, pd.DataFrame) else np.asarray(X)[rows]
        predicted[rows] = model.predict(X_rows)
        y_rows = y_um.iloc[rows] if isinstance(y_um, pd.Series) else y_values[rows]
        model.partial_fit(X_rows, y_rows)
    return OnlineRun(_compensated(y_values, predicted), model)
