r"""Can two causes be told apart? A paired test on their out-of-sample losses.

Two discrepancy models — the base plus cause :math:`a`, the base plus cause :math:`b` — are
scored on the same real rows under the same blocked folds (:func:`svrqp.gap.quantify.nested_errors`),
giving out-of-sample errors :math:`e_{a,i}` and :math:`e_{b,i}`. Their per-row loss
difference

.. math::

    d_i = e_{b,i}^2 - e_{a,i}^2,\qquad \bar d = \frac1n\sum_i d_i,

is positive on average when :math:`a` fits better. The rows are autocorrelated, so
:math:`\bar d` is resampled with the moving-block bootstrap within groups used for the shrink
interval (:func:`svrqp.gap.blocks.block_bootstrap`, block length from the autocorrelation of
:math:`d`): resampling rows in blocks pairs :math:`e_{a,i}` with :math:`e_{b,i}` and keeps
the dependence between neighbouring blocks' losses. The test of equal expected loss (in the
spirit of Diebold & Mariano 1995) uses the bootstrap distribution of :math:`\bar d^*` centred
on :math:`\bar d` (the null distribution of the mean difference):

.. math::

    p = \frac{1 + \#\{|\bar d^* - \bar d| \ge |\bar d|\}}{1 + N}.

:math:`a` and :math:`b` *cannot be told apart* when :math:`p \ge` :data:`TIE_ALPHA` — the data
do not show that either fits the real rows better. This is a statement about fit only; which
of the two carries information the other lacks is asked by the conditional tests of
:mod:`svrqp.gap.attribute`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from svrqp.gap.blocks import block_bootstrap, block_length

TIE_ALPHA = 0.05
"""Two causes whose paired loss test has a p-value at least this large cannot be told apart."""

N_PAIRED_BOOTSTRAP = 1000
"""Bootstrap resamples of the mean loss difference."""


@dataclass(frozen=True)
class PairedComparison:
    """Paired block-bootstrap comparison of two causes' out-of-sample losses.

    Attributes
    ----------
    mean_difference : float
        :math:`\\bar d`, mean of ``loss(b) - loss(a)`` per real row (squared target units).
    ci_low, ci_high : float
        95 % block-bootstrap interval of :math:`\\bar d`.
    p_value : float
        Two-sided p-value of "equal expected loss".
    """

    mean_difference: float
    ci_low: float
    ci_high: float
    p_value: float

    @property
    def tied(self) -> bool:
        """Whether the two causes cannot be told apart by their fit (``p_value >= TIE_ALPHA``)."""
        return self.p_value >= TIE_ALPHA


def paired_loss_test(
    errors_a: np.ndarray, errors_b: np.ndarray, groups: np.ndarray, rng: np.random.Generator
) -> PairedComparison:
    """Paired test of equal out-of-sample loss of two causes (see the module docstring).

    Parameters
    ----------
    errors_a, errors_b : ndarray, shape (n,)
        Out-of-sample errors on the real rows of the models with cause ``a`` and cause ``b``
        added (same rows, same folds).
    groups : ndarray of int, shape (n,)
        Group code per row (resampling stays within groups).
    rng : numpy.random.Generator
        Source of the resamples.

    Returns
    -------
    PairedComparison
    """
    d = errors_b**2 - errors_a**2
    mean = float(d.mean())
    index = block_bootstrap(groups, N_PAIRED_BOOTSTRAP, block_length(d, groups), rng)
    means = d[index].mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    extreme = int(np.sum(np.abs(means - mean) >= abs(mean)))
    return PairedComparison(mean, float(low), float(high), (1 + extreme) / (1 + N_PAIRED_BOOTSTRAP))
