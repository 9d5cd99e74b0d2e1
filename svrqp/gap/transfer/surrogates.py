r"""Surrogates of a candidate under "it carries nothing",
for the transfer tests of :mod:`svrqp.gap.transfer.ranking`.

Where a candidate's values fall does not matter under that null, so a surrogate moves them while
keeping what the null leaves free:

- A candidate that holds a level per run (:func:`svrqp.gap.transfer.between.is_run_level`) has its
  run levels permuted across the runs. Over :math:`k` runs there are only :math:`k!` orderings; when
  :math:`k! \le` :data:`EXACT_ORDERINGS` all of them are used (an exact test,
  :meth:`TransferSurrogates.orderings`), whose smallest reachable p-value is
  :math:`p_{\min} = s / k!`, with :math:`s` the orderings that leave the levels as they are
  (:meth:`TransferSurrogates.smallest_p`).
- Any other candidate is rotated circularly within every group
  (:func:`svrqp.gap.data.runs.shift_offsets`, which keeps its autocorrelation). What rotates is the
  part that the family's other inputs do not explain: least squares of the candidate on the family's
  design (without the candidate itself, when it is a model feature) leaves :math:`x = A c + u`, and
  a surrogate is :math:`A c + \mathrm{rot}(u)`; in prediction mode the design is the intercept and
  this is the plain rotation. One record cut into blocks is rotated as a whole, lifted at the seam
  by its end-minus-start change (:func:`svrqp.gap.data.runs.lift_steps`); so is a candidate whose
  ``rise`` is tested, in every run: a plain rotation of a drifting reading jumps at the seam, and
  its rise would take a shape no rise since a run's start has. The local form's surrogates
  also exchange run levels (:func:`exchange_run_levels`).
"""

from __future__ import annotations

import itertools
import math
from typing import Protocol

import numpy as np

from svrqp.gap.data import (
    RISE,
    GapData,
    group_slices,
    lift_steps,
    rotated_rows,
    shift_offsets,
    wrapped_part,
)
from svrqp.gap.transfer.between import permutation_floor


class Effect(Protocol):
    """What a surrogate needs of a candidate × transform
    (:class:`svrqp.gap.results.records.Effect`)."""

    column: str
    transform: str
    run_level: bool
    windows: np.ndarray | None


EXACT_ORDERINGS = 120
"""Most orderings of a run-level candidate's levels (five runs) that a test enumerates exactly; with
more runs it draws them (the Monte-Carlo resolution
then matches the smallest p-value, 1/720 or less)."""


class TransferSurrogates:
    """Surrogates of the candidates of one diagnosis.

    Parameters
    ----------
    data : GapData
        Prepared rows.
    design : ndarray
        The family's design on every row (``[1, X]`` in
        features mode, the intercept in prediction mode).
    rng, local_rng : numpy.random.Generator
        Sources of the draws (the ``local`` form's its own stream).
    lift : bool
        Whether a rotation is lifted at the seam (one record cut into blocks).
    """

    def __init__(self, data: GapData, design: np.ndarray, rng: np.random.Generator,
                 local_rng: np.random.Generator, lift: bool):
        self.data, self.design, self.rng, self.local_rng, self.lift = (
            data, design, rng, local_rng, lift,
        )

    def run_levels(self, effect: Effect) -> np.ndarray:
        """The candidate's mean over each run where it is known, in run order."""
        x = self.data.C[:, self.data.candidates.index(effect.column)]
        known = np.flatnonzero(np.isfinite(x))
        return np.array([x[known[s]].mean() for s in group_slices(self.data.groups[known])])

    def orderings(self, effect: Effect) -> list[np.ndarray] | None:
        """Every ordering of a run-level candidate's levels when
        there are at most :data:`EXACT_ORDERINGS`, else None."""
        if not effect.run_level:
            return None
        k = self.run_levels(effect).size
        if math.factorial(k) > EXACT_ORDERINGS:
            return None
        return [np.array(order) for order in itertools.permutations(range(k))]

    def surrogate(self, effect: Effect, count: int,
                  orders: list[np.ndarray] | None = None) -> list[np.ndarray]:
        """``count`` surrogates of the candidate (rotated within groups, or run levels permuted:
        drawn at random, or the ``orders`` given)."""
        data = self.data
        x = data.C[:, data.candidates.index(effect.column)]
        known = np.flatnonzero(np.isfinite(x))
        groups = data.groups[known]
        rng = self.local_rng if effect.windows is not None else self.rng
        k = len(group_slices(groups))
        out = []
        if effect.run_level:
            for order in orders if orders is not None else [rng.permutation(k)
                                                            for _ in range(count)]:
                xs = x.copy()
                xs[known] = exchange_run_levels(x[known], groups, order)
                out.append(xs)
            return out
        # The part of the candidate that the family's other
        # inputs explain stays where it is; the rest rotates.
        A = self._other_inputs(effect.column)[known]
        explained = A @ np.linalg.lstsq(A, x[known], rcond=None)[0]
        own = x[known] - explained
        offsets = shift_offsets(groups, count, rng, own)
        index = rotated_rows(groups, offsets)
        # A rise starts at 0 and drifts: rotated plainly it would jump at the seam, a shape no real
        # rise has, so its rotations are lifted there too (the rise of the rotated increments).
        lift = self.lift or effect.transform == RISE
        lifted = wrapped_part(index, groups) * lift_steps(own, groups) if lift else None
        for i, rows in enumerate(index):
            xs = x.copy()
            xs[known] = explained + (own[rows] if lifted is None else own[rows] + lifted[i])
            if effect.windows is not None:  # a local form: its run levels are exchanged as well
                xs[known] = exchange_run_levels(xs[known], groups, rng.permutation(k))
            out.append(xs)
        return out

    def _other_inputs(self, column: str) -> np.ndarray:
        """The family's design without the candidate itself
        (a model feature whose rate or lag is tested)."""
        A, features = self.design, self.data.features
        if column in features and A.shape[1] == 1 + len(features):  # [1, X] of the features mode
            return np.delete(A, 1 + features.index(column), axis=1)
        return A

    def smallest_p(self, effect: Effect) -> float:
        """The smallest p-value an exact test
        (:meth:`svrqp.gap.transfer.ranking.TransferRanker.exact_p`)
        can give: the orderings that leave the run levels unchanged
        (:func:`svrqp.gap.transfer.between.permutation_floor`)."""
        return permutation_floor(self.run_levels(effect))


def exchange_run_levels(x: np.ndarray, groups: np.ndarray, order: np.ndarray) -> np.ndarray:
    r"""``x`` with the run means exchanged by the permutation :math:`\pi` = ``order`` of the runs.

    :math:`x_s(t) = x(t) - \bar x_g + \bar x_{\pi(g)}` on the rows of run :math:`g`: the surrogate
    of a run-level candidate, and applied to a series already rotated within runs (with a random
    ``order``), a surrogate of the ``local`` form's test (module docstring).
    """
    slices = group_slices(groups)
    means = np.array([x[s].mean() for s in slices])
    shift = means[order] - means
    out = x.copy()
    for s, d in zip(slices, shift, strict=False):
        out[s] += d
    return out


def besag_clifford_p(hits: list[bool], stop: int) -> float:
    """Sequential Monte-Carlo p-value (Besag & Clifford 1991) of surrogates drawn in order.

    ``h/S_h`` once ``stop`` surrogates reached the statistic, else ``(1 + hits)/(1 + drawn)``.
    """
    if sum(hits) >= stop:
        return stop / (int(np.flatnonzero(hits)[stop - 1]) + 1)
    return (1 + sum(hits)) / (1 + len(hits))
