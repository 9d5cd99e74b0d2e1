"""Small signal-processing pieces shared by the simulators."""

from __future__ import annotations

import numpy as np
import scipy.signal


def first_order_lag(signal: np.ndarray, dt: float, tau: float) -> np.ndarray:
    r"""Exact first-order lag of a step-held signal, starting in equilibrium (axis 0 is time).

    ``dt`` (the sample period) and ``tau`` (the time constant, 0 for no lag) share one unit.

    .. math:: y_{k+1} = e^{-\Delta t/\tau} y_k + (1 - e^{-\Delta t/\tau}) x_k,\qquad y_0 = x_0.
    """
    signal = np.asarray(signal, dtype=float)
    if tau == 0:
        return signal.copy()
    decay = np.exp(-dt / tau)
    lagged = np.empty_like(signal)
    lagged[0] = signal[0]
    # y_k for k >= 1 filters x_0 .. x_{k-1}: a one-step delayed recursive filter.
    lagged[1:], _ = scipy.signal.lfilter(
        [1.0 - decay], [1.0, -decay], signal[:-1], axis=0, zi=decay * signal[:1]
    )
    return lagged
