r"""A permutation test that knows where and how a localised effect acts (imports nothing of ``svrqp.gap``).

The engine's ``local`` form must find a window and then test the column in it; this test is given the
effect's true profile :math:`w(t)` along its axis (zero outside the stretch: an indicator, a bump or a
decaying transient inside it) and only asks which offered column scales the effect there. For a column
:math:`x` the statistic is the real-row RMSE of the leave-one-run-out refit with

.. math::

    w(t), \qquad x(t)\,w(t)

added to the model's own inputs (:func:`transfer_oracle.logo_rmse`). Under "this column carries
nothing", both where its values fall within a run and which run holds which level are arbitrary, so a
surrogate is :math:`x` rotated circularly within every run with its run means exchanged by a random
permutation of the runs (train run included: the refit keeps it in every fit). A column that holds one
value per run is not moved by a rotation, and when its runs allow at most :data:`EXACT_MAX` orderings
every ordering is refitted: :math:`p = \#\{\pi : \mathrm{RMSE}_\pi \le \mathrm{RMSE}\} / k!`, the
observed ordering included, at least :math:`1/k!`. Otherwise :math:`p = (1 + \#\{s : \mathrm{RMSE}_s
\le \mathrm{RMSE}\}) / (1 + N)` over :data:`DRAWS` random surrogates.

The p-values of every offered column go through Benjamini–Hochberg (as a user's diagnosis would test
every column it is offered), and the truth's q-value says whether even a test that knows the profile can name
it at the false-discovery level :data:`FDR`: where it cannot, DESIGN §4's answer is no verdict. It is a
reference, not a bound on every test's power: a test that searches windows can be luckier on one record.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pandas as pd
from scipy.stats import false_discovery_control
from transfer_oracle import Predict, logo_rmse, lstsq_predict

FDR = 0.05
"""False-discovery level of DESIGN §4's verdict ("beyond chance, multiple-testing controlled")."""

DRAWS = 399
"""Random surrogates of a column that varies within runs (or whose runs allow too many orderings):
smallest p-value 1/400, below Benjamini–Hochberg's first threshold 0.05/8 for the suite's eight columns."""

EXACT_MAX = 720
"""Most orderings of a run-constant column's levels refitted one by one (six runs)."""


def surrogate(x: np.ndarray, groups: np.ndarray, order: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """``x`` rotated by ``shifts[i]`` rows within the ``i``-th run and given run ``order[i]``'s mean there."""
    runs = pd.unique(groups)
    rows = [np.flatnonzero(groups == g) for g in runs]
    means = np.array([x[r].mean() for r in rows])
    out = np.empty_like(x)
    for i, r in enumerate(rows):
        out[r] = np.roll(x[r] - means[i], shifts[i]) + means[order[i]]
    return out


def stretch_rmse(y: np.ndarray, base: np.ndarray, x: np.ndarray, w: np.ndarray, groups: np.ndarray,
                 real: np.ndarray, predict: Predict = lstsq_predict) -> float:
    """Real-row RMSE of the leave-one-run-out refit with ``[w, x w]`` added to ``base``."""
    return logo_rmse(y, base, [np.column_stack([w, x * w])], groups, real, predict)


def stretch_p(y: np.ndarray, base: np.ndarray, x: np.ndarray, w: np.ndarray, groups: np.ndarray, real: np.ndarray,
              rng: np.random.Generator, predict: Predict = lstsq_predict, observed: float | None = None,
              draws: int = DRAWS) -> float:
    """Permutation p-value of the column ``x`` with the profile ``w`` (module docstring); rows sorted within runs.
    ``observed``: its :func:`stretch_rmse`, when the caller has it already."""
    def rmse(column: np.ndarray) -> float:
        return stretch_rmse(y, base, column, w, groups, real, predict)

    return surrogate_p(rmse, x, groups, rng, observed, draws)


def surrogate_p(rmse, x: np.ndarray, groups: np.ndarray, rng: np.random.Generator,
                observed: float | None = None, draws: int = DRAWS) -> float:
    """Permutation p-value of a statistic ``rmse(column)`` (smaller is better) of the column ``x`` against its
    surrogates (:func:`surrogate`; module docstring): every ordering of a run-constant column's levels when there
    are at most :data:`EXACT_MAX`, else ``draws`` random rotations and orderings."""
    observed = (rmse(x) if observed is None else observed) * (1 + 1e-12)
    runs = pd.unique(groups)
    k = runs.size
    constant = all(np.ptp(x[groups == g]) <= 1e-12 * (1 + np.abs(x).max()) for g in runs)
    if constant and math.factorial(k) <= EXACT_MAX:
        zero = np.zeros(k, dtype=int)
        hits = sum(rmse(surrogate(x, groups, np.array(order), zero)) <= observed
                   for order in itertools.permutations(range(k)))
        return hits / math.factorial(k)
    sizes = np.array([np.sum(groups == g) for g in runs])
    hits = sum(rmse(surrogate(x, groups, rng.permutation(k), rng.integers(0, sizes))) <= observed
               for _ in range(draws))
    return (1 + hits) / (1 + draws)


def told_test(table: pd.DataFrame, y: np.ndarray, base: np.ndarray, w: np.ndarray, columns: tuple[str, ...],
              group: str, real: np.ndarray, seed: int, predict: Predict = lstsq_predict) -> pd.DataFrame:
    """Every offered column tested with the profile ``w``: its refit's real-row ``rmse``, its ``p`` (:func:`stretch_p`)
    and its Benjamini–Hochberg ``q`` over the columns, indexed by column."""
    rng = np.random.default_rng(seed)
    groups = table[group].to_numpy()
    xs = {c: table[c].to_numpy(float) for c in columns}
    rmse = [stretch_rmse(y, base, xs[c], w, groups, real, predict) for c in columns]
    p = [stretch_p(y, base, xs[c], w, groups, real, rng, predict, observed) for c, observed in zip(columns, rmse)]
    return pd.DataFrame({"rmse": rmse, "p": p, "q": false_discovery_control(p, method="bh")}, index=list(columns))


def told_verdict(tests: pd.DataFrame) -> str | None:
    """The column the told test names: the best-transferring (smallest ``rmse``) of those with ``q`` below
    :data:`FDR`, as a verdict names the best of the significant causes; None when none is."""
    significant = tests[tests.q < FDR]
    return None if significant.empty else str(significant.rmse.idxmin())
