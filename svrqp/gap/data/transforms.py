r"""Transforms of a candidate column that an unmodelled effect may follow.

A thermal error rarely follows a sensor reading one-to-one. The diagnosis therefore tests
each candidate column :math:`x(t)` in three forms, all computed along the ``--order`` axis
:math:`t` and restarted at the start of every ``--group`` (run):

``level``
    :math:`x(t)` itself (a static, proportional effect).
``rate``
    :math:`\dot x(t) = \mathrm{d}x/\mathrm{d}t`, by second-order central differences on the
    possibly uneven grid of :math:`t` (one-sided at the ends of a group) —
    :func:`numpy.gradient`. Thermal gradients during warm-up follow the rate.
``lag``
    thermal inertia: the first-order low-pass response :math:`x_\tau` of a body with time
    constant :math:`\tau` driven by :math:`x`, minus the signal,

    .. math::

        \tau\,\dot x_\tau = x - x_\tau,\qquad x_\tau(t_0) = x(t_0),\qquad
        \ell_\tau(t) = x_\tau(t) - x(t).

    Discretised exactly for a signal held constant between samples (zero-order hold):
    :math:`x_{\tau,k} = x_{\tau,k-1} + \alpha_k (x_k - x_{\tau,k-1})`,
    :math:`\alpha_k = 1 - e^{-(t_k - t_{k-1})/\tau}`. The filter starts in equilibrium with
    the first sample of each group. :math:`\ell_\tau \approx -\tau \dot x` for a slow signal,
    and together with :math:`x` it spans the filtered reading :math:`x_\tau = x + \ell_\tau`,
    which is what a structure with thermal inertia responds to.

``rise``
    heating since the run's start, :math:`x(t) - x(t_0)` with :math:`t_0` the run's first row (the
    ``lag`` at :math:`\tau = \infty`, where the filter holds its first value). An effect that
    builds up over the run from wherever the run started (a nut warmed by the axis's duty since
    the run began) follows the rise, not any finite lag. It enters a refit alone, one column: with
    :math:`x` beside it the pair would add each run's starting level, an offset between runs that a
    few held-out runs cannot pin down, and inside the lag's time-constant choice the finite lags,
    fitted better on the fit's own rows, would be chosen and extrapolate (on two withheld heating
    scenarios the rise alone transferred +0.73 and +0.53 where the lag grid with it transferred
    −1.6 and −8.1).

The time constant is searched on :func:`tau_grid`, a geometric grid between a few sampling
intervals and half the typical run length.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter, savgol_filter

from svrqp.exceptions import ProblemError

N_TAU = 8
"""Number of time constants on the grid searched for the ``lag`` transform."""

CONSTANT_TOLERANCE = 1e-12
"""Spread, relative to the values' magnitude (plus one), below which a column counts as constant."""

MIN_STRETCH = 16
"""Rows of one sampling interval below which :func:`lowpass_columns` steps them in Python."""

SAMPLING_TOLERANCE = 1e-9
"""Relative difference below which two filter coefficients (two sampling intervals) count as one:
differences of times far from zero (1e5 min in steps of 0.1) carry rounding errors near 1e-10."""


def negligible(spread: np.ndarray, values: np.ndarray, axis: int | None = 0) -> np.ndarray:
    """Whether each ``spread`` (a standard deviation or a range of ``values`` along ``axis``) is
    zero up to rounding: at most :data:`CONSTANT_TOLERANCE` × (1 + max |values|).

    One test for every "is this column constant?" decision of the diagnosis, so that a column
    dropped as constant in one step is dropped in all of them.
    """
    return np.asarray(spread) <= CONSTANT_TOLERANCE * (1.0 + np.abs(values).max(axis=axis))


def standardised(columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns centred and scaled on the rows given, and which of them vary (:func:`negligible`).

    Returns
    -------
    Z : ndarray, same shape as ``columns``
        Standardised columns; a constant column becomes zeros.
    varying : ndarray of bool, shape (q,)
        The columns that are not constant (callers that drop constants take ``Z[:, varying]``).
    """
    centred = columns - columns.mean(axis=0)
    scale = centred.std(axis=0)
    varying = ~negligible(scale, columns)
    return np.divide(centred, scale, out=np.zeros_like(centred), where=varying), varying


def group_slices(group_codes: np.ndarray) -> list[slice]:
    """Contiguous slices of rows that share a group code (rows must be sorted by group).

    Parameters
    ----------
    group_codes : ndarray of int, shape (n,)
        Group code of each row, sorted so that every group is one contiguous run.

    Returns
    -------
    list of slice
        One slice per group, in row order.
    """
    codes = np.asarray(group_codes)
    if codes.size == 0:
        return []
    starts = np.flatnonzero(np.r_[True, codes[1:] != codes[:-1]])
    stops = np.r_[starts[1:], codes.size]
    if np.unique(codes).size != starts.size:
        raise ProblemError("group_codes: rows of a group must be contiguous (sort by group first)")
    return [slice(int(a), int(b)) for a, b in zip(starts, stops, strict=False)]


def rate(x: np.ndarray, t: np.ndarray, group_codes: np.ndarray) -> np.ndarray:
    """Derivative :math:`\\mathrm{d}x/\\mathrm{d}t` within each group.

    Parameters
    ----------
    x : ndarray, shape (n,) or (n, c)
        Signal(s), rows sorted by group and, within a group, by strictly increasing ``t``.
    t : ndarray, shape (n,)
        Order axis (time in min or position in mm).
    group_codes : ndarray of int, shape (n,)
        Group code of each row.

    Returns
    -------
    ndarray, same shape as ``x``
        The rate in units of ``x`` per unit of ``t``.
    """
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    for rows in group_slices(group_codes):
        out[rows] = np.gradient(x[rows], t[rows], axis=0)
    return out


def rise(x: np.ndarray, t: np.ndarray, group_codes: np.ndarray) -> np.ndarray:
    """The rise since each group's first row, :math:`x(t) - x(t_0)` (shape of ``x``; rows sorted by
    group; ``t`` is not needed: the order only decides which row is first)."""
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    for rows in group_slices(group_codes):
        out[rows] = x[rows] - x[rows.start]
    return out


DYNAMIC = {"rate": rate, "rise": rise}
"""The one-column transforms of a candidate's dynamics within a run, by name: each computed along
the order axis and restarted at each group, as ``f(x, t, group_codes)`` → one value per row. A new
transform of this kind is its function in this module and its entry here; the transfer ranking,
the verdict's refit and the within-real-rows banks read it from this table."""

WITHIN_RUN = (*DYNAMIC, "lag")
"""The transforms that vary within a run whatever the
candidate's run levels do (rotated within runs)."""

TRANSFORMS = ("level", *DYNAMIC, "lag")
"""Names of the transforms, in the order they are refitted and reported."""

RISE = "rise"
"""The rise since the run's start (:func:`rise`): not offered for a model feature, beside which it
adds only the feature's starting level per run."""


def filter_coefficients(t: np.ndarray, group_codes: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """:math:`\alpha_k` of every row and time constant, shape (n, m); 1 at each group's first row.

    A coefficient of 1 restarts the filter in equilibrium with that row's value.
    """
    taus = np.asarray(taus, dtype=float)
    if np.any(taus <= 0):
        raise ProblemError("taus: time constants must be positive")
    dt = np.diff(t, prepend=t[:1])
    starts = [rows.start for rows in group_slices(group_codes)]
    # the step into a group is no interval (the order restarts there: it may be negative)
    dt[starts] = 0.0
    alpha = -np.expm1(-dt[:, None] / taus[None, :])
    alpha[starts] = 1.0
    return alpha


def lowpass_columns(X: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """First-order low-pass responses of several series at once, shape (n, s, m).

    Parameters
    ----------
    X : ndarray, shape (n, s)
        ``s`` signals on the same rows.
    alpha : ndarray, shape (n, m)
        Filter coefficients (:func:`filter_coefficients`).

    Returns
    -------
    ndarray, shape (n, s, m)
        Response of every signal for every time constant.

    Notes
    -----
    The recursion is sequential in the rows. On a stretch of rows sampled at one interval
    :math:`\alpha` is constant, and the stretch is a linear time-invariant filter that
    :func:`scipy.signal.lfilter` runs in compiled code, started from the state the rows
    before it left; rows between such stretches (uneven sampling) are stepped one by one.
    """
    X = np.asarray(X, dtype=float)
    n, m = X.shape[0], alpha.shape[1]
    out = np.empty((n, X.shape[1], m))
    state = np.zeros((X.shape[1], m))
    for start, stop in _even_stretches(alpha):
        if stop - start < MIN_STRETCH:
            for k in range(start, stop):
                state += alpha[k] * (X[k][:, None] - state)
                out[k] = state
            continue
        for j in range(m):
            a = alpha[start, j]
            out[start:stop, :, j], _ = lfilter([a], [1.0, a - 1.0], X[start:stop], axis=0,
                                               zi=((1.0 - a) * state[:, j])[None, :])
        state = out[stop - 1].copy()
    return out


def _even_stretches(alpha: np.ndarray) -> list[tuple[int, int]]:
    """Row ranges ``[start, stop)`` over which every column of ``alpha`` is constant, to a relative
    :data:`SAMPLING_TOLERANCE`."""
    n = alpha.shape[0]
    if n == 0:
        return []
    changes = np.any(np.abs(np.diff(alpha, axis=0)) > SAMPLING_TOLERANCE * alpha[1:], axis=1)
    starts = np.r_[0, np.flatnonzero(changes) + 1]
    return list(zip(starts.tolist(), np.r_[starts[1:], n].tolist(), strict=False))


def lowpass(x: np.ndarray, t: np.ndarray, group_codes: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """First-order low-pass responses :math:`x_\tau` for every time constant in ``taus``.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Signal, rows sorted by group and by ``t`` within a group.
    t : ndarray, shape (n,)
        Order axis.
    group_codes : ndarray of int, shape (n,)
        Group code of each row; the filter restarts in equilibrium at each group start.
    taus : ndarray, shape (m,)
        Positive time constants, in units of ``t``.

    Returns
    -------
    ndarray, shape (n, m)
        Column ``j`` is the response with time constant ``taus[j]``.
    """
    x = np.asarray(x, dtype=float)
    return lowpass_columns(x[:, None], filter_coefficients(t, group_codes, taus))[:, 0, :]


def lag(x: np.ndarray, t: np.ndarray, group_codes: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """The ``lag`` transform :math:`\\ell_\\tau = x_\\tau - x` for every ``tau`` (shape (n, m))."""
    return lowpass(x, t, group_codes, taus) - np.asarray(x, dtype=float)[:, None]


def tau_grid(t: np.ndarray, group_codes: np.ndarray, n_tau: int = N_TAU) -> np.ndarray:
    """Geometric grid of time constants suited to the sampling and the run lengths.

    From two median sampling intervals (or 1/100 of the median run length, if larger) to
    half the median run length.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Order axis, sorted within groups.
    group_codes : ndarray of int, shape (n,)
        Group code of each row.
    n_tau : int
        Number of grid points.

    Returns
    -------
    ndarray, shape (n_tau,)
    """
    steps, spans = [], []
    for rows in group_slices(group_codes):
        tg = t[rows]
        d = np.diff(tg)
        steps.extend(d[d > 0])
        spans.append(tg[-1] - tg[0])
    span = float(np.median(spans))
    if not steps or span <= 0:
        raise ProblemError("order: the order column does not increase within any group")
    low = max(2.0 * float(np.median(steps)), span / 100.0)
    high = span / 2.0
    if high <= low:
        high = 2.0 * low
    return np.geomspace(low, high, n_tau)



SMOOTH_WINDOW = 21
"""Savitzky–Golay window of :func:`smooth`, in samples (never more than 1/8 of a group)."""

SMOOTH_ORDER = 2
"""Polynomial order of :func:`smooth`."""


def smooth(x: np.ndarray, group_codes: np.ndarray) -> np.ndarray:
    """Zero-phase Savitzky–Golay smoothing of each column within each group.

    A quadratic fitted over :data:`SMOOTH_WINDOW` samples (at most an eighth of the group,
    and odd) cuts the variance of white sensor noise about ninefold and, being symmetric,
    shifts no phase: it cannot imitate a lag or a rate.

    Parameters
    ----------
    x : ndarray, shape (n,) or (n, c)
        Signal(s), rows sorted by group and order.
    group_codes : ndarray of int, shape (n,)
        Group code of each row.

    Returns
    -------
    ndarray, same shape as ``x``
    """
    x = np.asarray(x, dtype=float)
    out = x.copy()
    for rows in group_slices(group_codes):
        window = min(SMOOTH_WINDOW, (rows.stop - rows.start) // 8)
        window -= 1 - window % 2  # odd
        if window > SMOOTH_ORDER + 1:
            out[rows] = savgol_filter(x[rows], window, SMOOTH_ORDER, axis=0)
    return out
