r"""Is there a gap beyond chance? Tests on a residual before any cause is named.

Excess error
    The mean squared residual on the real rows, :math:`s_r^2`, against the out-of-sample
    mean squared residual on the train rows, :math:`s_t^2` (the error to expect where
    nothing is missing, :mod:`svrqp.gap.model.baseline`). Under "no gap" their ratio is
    F-distributed; because the rows are autocorrelated, each sample counts with its
    effective size (Bartlett's AR(1) correction)

    .. math::

        F = \frac{s_r^2}{s_t^2},\qquad
        n_{\mathrm{eff}} = n\,\frac{1-\rho_1}{1+\rho_1},\qquad
        p = P\bigl(F_{n_{\mathrm{eff},r},\,n_{\mathrm{eff},t}} \ge F\bigr),

    with :math:`\rho_1` the lag-1 autocorrelation of each residual
    (:func:`svrqp.gap.data.runs.lag1_autocorrelation`).

Excess over noise
    The same F test against the noise variance estimated from successive differences within
    groups (von Neumann's mean square successive difference),

    .. math::

        \hat\sigma^2 = \frac{\sum_g \sum_k (r_{g,k} - r_{g,k-1})^2}{2 \sum_g (n_g - 1)},

    which a smooth error leaves almost untouched (coloured noise makes :math:`\hat\sigma^2`
    too small, so this test errs towards "gap"; the surrogate tests of the attribution remain
    the guard against naming a cause).

Decision
    The gate is one-sided. A gap exists only when the real rows fit worse than the train rows
    (:math:`s_r > s_t`, both out of sample: the model never saw the real rows, and the train
    reference is cross-validated, or in prediction mode the prediction's own train-row error)
    and that excess is beyond chance against the train reference or the noise level
    (:math:`\min(p_\mathrm{excess}, p_\mathrm{noise}) < \alpha`). Real rows that fit no worse
    than the train rows are no gap, whatever the noise test says; no cause is then named.

Whiteness
    The Ljung–Box statistic of the real-row residual, pooled over groups,

    .. math::

        Q = n(n+2)\sum_{h=1}^{H}\frac{\hat\rho_h^2}{n-h} \sim \chi^2_H ,

    the residual test of system identification (Ljung, *System Identification*, §16.6).
    Measurement noise is often coloured, so a non-white residual alone is reported but does
    not decide anything; the decision on causes rests on the surrogate tests of
    :mod:`svrqp.gap.within.surrogate_tests`, which keep the residual's autocorrelation.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from svrqp.gap.contract import ALPHA
from svrqp.gap.data import group_slices, lag1_autocorrelation
from svrqp.gap.results.records import GateResult
from svrqp.metrics import rms

LJUNG_BOX_LAGS = 20
"""Largest lag :math:`H` of the Ljung–Box statistic (fewer for short groups)."""



def effective_size(residual: np.ndarray, groups: np.ndarray) -> float:
    """Effective number of independent rows of an AR(1)-like residual."""
    rho = lag1_autocorrelation(residual, groups)
    return max(2.0, len(residual) * (1 - rho) / (1 + rho))


def excess_error_pvalue(real: np.ndarray, real_groups: np.ndarray, train: np.ndarray, train_groups: np.ndarray) -> float:
    """One-sided p-value that the real-row mean square exceeds the train reference's."""
    ms_real, ms_train = float(np.mean(real**2)), float(np.mean(train**2))
    if ms_train <= 0:
        return 0.0 if ms_real > 0 else 1.0
    ratio = ms_real / ms_train
    return float(stats.f.sf(ratio, effective_size(real, real_groups), effective_size(train, train_groups)))


def successive_difference_variance(residual: np.ndarray, groups: np.ndarray) -> float:
    """Noise variance from successive differences within groups (see module docstring)."""
    num = den = 0.0
    for rows in group_slices(groups):
        d = np.diff(residual[rows])
        num += float(d @ d)
        den += 2.0 * d.size
    return num / den if den > 0 else 0.0


def noise_pvalue(real: np.ndarray, real_groups: np.ndarray) -> float:
    """One-sided p-value that the real-row mean square exceeds the noise level."""
    noise = successive_difference_variance(real, real_groups)
    ms_real = float(np.mean(real**2))
    if noise <= 0:
        return 0.0 if ms_real > 0 else 1.0
    n_pairs = len(real) - len(group_slices(real_groups))
    return float(stats.f.sf(ms_real / noise, effective_size(real, real_groups), max(n_pairs, 1)))


def ljung_box_pvalue(residual: np.ndarray, groups: np.ndarray, lags: int = LJUNG_BOX_LAGS) -> float:
    """Ljung–Box p-value with autocorrelations pooled over groups (each group demeaned)."""
    slices = group_slices(groups)
    shortest = min(s.stop - s.start for s in slices)
    H = int(min(lags, max(1, shortest // 4)))
    num = np.zeros(H)
    den = 0.0
    for rows in slices:
        e = residual[rows] - residual[rows].mean()
        den += float(e @ e)
        for h in range(1, H + 1):
            num[h - 1] += float(e[h:] @ e[:-h])
    if den <= 0:
        return 1.0
    n = len(residual)
    rho = num / den
    Q = n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, H + 1)))
    return float(stats.chi2.sf(Q, H))


def gate(real: np.ndarray, real_groups: np.ndarray, train: np.ndarray, train_groups: np.ndarray) -> GateResult:
    """Run the excess-error and whiteness tests on a real-row residual.

    Parameters
    ----------
    real : ndarray
        Residual on the real rows (before or after adding an effect).
    real_groups : ndarray of int
        Group code per real row (contiguous groups).
    train : ndarray
        Out-of-sample reference residual on the train rows.
    train_groups : ndarray of int
        Group code per train row.

    Returns
    -------
    GateResult
    """
    train_rmse = float(rms(train))
    real_rmse = float(rms(real))
    return GateResult(
        train_rmse=train_rmse,
        real_rmse=real_rmse,
        ratio=real_rmse / train_rmse if train_rmse > 0 else (float("inf") if real_rmse > 0 else float("nan")),
        p_excess=excess_error_pvalue(real, real_groups, train, train_groups),
        noise_rmse=float(np.sqrt(successive_difference_variance(real, real_groups))),
        p_noise=noise_pvalue(real, real_groups),
        p_white=ljung_box_pvalue(real, real_groups),
        rho1=lag1_autocorrelation(real, real_groups),
    )


def gap_detected(result: GateResult) -> bool:
    """Whether the gate finds a gap beyond chance (see "Decision" in the module docstring)."""
    return result.real_rmse > result.train_rmse and min(result.p_excess, result.p_noise) < ALPHA
