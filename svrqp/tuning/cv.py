r"""The k-fold cross-validation score of a set of candidates, on Gram matrices shared across fits.

**Score.** Every candidate :math:`\theta = (C, \varepsilon, \gamma)` (LS-SVR: :math:`(C, \gamma)`)
is scored by its k-fold cross-validation mean squared error

.. math::

    \operatorname{CV}(\theta) = \frac1k \sum_{f=1}^{k} \frac{1}{|V_f|}
    \sum_{i \in V_f} \bigl(y_i - f_\theta^{(-f)}(x_i)\bigr)^2 ,

where :math:`f_\theta^{(-f)}` is fitted on every fold but :math:`V_f` — the unweighted mean over
folds, i.e. minus scikit-learn's ``mean_test_score`` with ``scoring="neg_mean_squared_error"``.
S0 and S2 choose (C, g) and (C, σ) by 5-fold CV; S1 uses the same score as the GA fitness.

**Shared Gram matrices.** For one :math:`\gamma` the RBF Gram matrix of the whole data set is
computed once; the training block :math:`K_{TT}` and the validation block :math:`K_{VT}` of every
fold are slices of it, and every :math:`(C, \varepsilon)` of that fold reuses them, fitted in
ascending C so that each fit can start from the previous one
(:func:`svrqp.solvers.epsilon_svr.fit_on_gram`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import joblib
import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from sklearn.model_selection import KFold, check_cv

from svrqp.exceptions import ProblemError, SolverError
from svrqp.formulations import ls_svr
from svrqp.kernels import gram
from svrqp.solvers.epsilon_svr import fit_on_gram
from svrqp.tuning.execution import Progress
from svrqp.tuning.result import SearchResult, warn_on_edges


@dataclass(frozen=True)
class FitSettings:
    """How every fit of a search is computed: the model,
    its solver and accuracy, warm starts along C."""

    model: str
    solver: str
    tol: float
    warm_start: bool


@dataclass(frozen=True)
class Fold:
    """One fold on a shared Gram matrix: fit on
    :math:`(K_{TT}, y_T)`, validate on :math:`(K_{VT}, y_V)`."""

    K_train: NDArray[np.float64]
    y_train: NDArray[np.float64]
    K_valid: NDArray[np.float64]
    y_valid: NDArray[np.float64]


def folds(cv: int | Any, X: NDArray, y: NDArray,
          groups: ArrayLike | None) -> list[tuple[NDArray, NDArray]]:
    """The (train, validation) index pairs of ``cv``: a number of contiguous folds or a splitter."""
    if isinstance(cv, int | np.integer) and not 2 <= cv <= X.shape[0]:
        raise ProblemError(f"folds must be between 2 and n_samples = {X.shape[0]}, got {cv}")
    splitter = KFold(int(cv)) if isinstance(cv, int | np.integer) else check_cv(cv)
    return list(splitter.split(X, y, groups))


def _fold_chain(
    key: tuple[int, int], fold: Fold, epsilon: float | None, Cs: NDArray, fit: FitSettings
) -> tuple[tuple[int, int], NDArray[np.float64]]:
    """Validation MSE of one fold for each C of ``Cs`` (ascending); ``inf`` where a fit failed.

    ``key`` is handed back with the result so results can be gathered in any arrival order.
    """
    K_train, y_train, K_valid, y_valid = fold.K_train, fold.y_train, fold.K_valid, fold.y_valid
    mse = np.full(Cs.size, np.inf)
    previous = None
    for index, C in enumerate(Cs):
        try:
            if fit.model == "svr":
                coef, b, previous = fit_on_gram(K_train, y_train, C, epsilon, fit.solver, fit.tol,
                                                previous if fit.warm_start else None)
            else:
                coef, b, _ = ls_svr.solve_cholesky_schur(K_train, y_train, C)
        except SolverError:
            previous = None  # do not warm-start from a failed solve
            continue
        mse[index] = np.mean((y_valid - (K_valid @ coef + b)) ** 2)
    return key, mse


def cv_mse(
    X: NDArray,
    y: NDArray,
    candidates: pd.DataFrame,
    folds: list[tuple[NDArray, NDArray]],
    fit: FitSettings,
    progress: Progress | None,
) -> NDArray[np.float64]:
    """Validation MSE, shape (n_folds, n_candidates), of every candidate row (C, [epsilon,] gamma).

    The joblib backend must already be configured (see :meth:`Execution.parallel
    <svrqp.tuning.execution.Execution.parallel>`).
    """
    chain_keys = ["gamma"] if fit.model == "lssvr" else ["gamma", "epsilon"]
    chains = [(key, rows.sort_values("C"))
              for key, rows in candidates.groupby(chain_keys, sort=True)]

    def tasks():
        K, K_gamma = None, None
        for chain_index, ((gamma, *epsilon), rows) in enumerate(chains):
            if gamma != K_gamma:  # chains are sorted by gamma: one Gram matrix per gamma
                K, K_gamma = gram(X, kernel="rbf", gamma=gamma), gamma
            for fold_index, (train, valid) in enumerate(folds):
                fold = Fold(K[np.ix_(train, train)], y[train], K[np.ix_(valid, train)], y[valid])
                yield joblib.delayed(_fold_chain)(
                    (fold_index, chain_index), fold, epsilon[0] if epsilon else None,
                    rows["C"].to_numpy(), fit)

    mse = np.full((len(folds), len(candidates)), np.inf)
    total = len(chains) * len(folds)
    results = joblib.Parallel(return_as="generator_unordered")(tasks())
    for done, ((fold_index, chain_index), fold_mse) in enumerate(results, start=1):
        mse[fold_index, chains[chain_index][1].index.to_numpy()] = fold_mse
        if progress is not None:
            progress(done, total)
    return mse


def _scored_table(candidates: pd.DataFrame, mse: NDArray[np.float64]) -> pd.DataFrame:
    failed = ~np.isfinite(mse)
    if np.all(failed.any(axis=0)):
        raise SolverError("every candidate had at least one failed fit; try another solver or "
                          "tolerance")
    finite = np.where(failed, 0.0, mse)
    table = candidates.copy()
    table["mse"] = np.where(failed.any(axis=0), np.inf, finite.mean(axis=0))
    table["mse_std"] = np.where(failed.any(axis=0), np.nan, finite.std(axis=0))
    table["failed_folds"] = failed.sum(axis=0)
    return table.sort_values("mse", kind="stable").reset_index(drop=True)


def scored_result(method: str, model: str, candidates: pd.DataFrame, mse: NDArray[np.float64],
                  elapsed_s: float, convergence_mse: NDArray[np.float64] | None = None,
                  bounds: dict[str, tuple[float, float]] | None = None) -> SearchResult:
    """The :class:`SearchResult` of ``candidates`` with fold MSEs ``mse`` (n_folds, n_candidates).

    Each candidate scores the mean over folds, ``inf`` if any of its fits failed; the table is
    sorted by score (stable, so ties keep the candidates' order) and its first row is the best.
    ``bounds`` are the searched ranges (default: each parameter's smallest and largest candidate,
    for those given more than one value); a best value on an edge warns
    (:class:`~svrqp.tuning.result.SearchEdgeWarning`).
    """
    table = _scored_table(candidates, mse)
    names = ["C", "gamma"] if model == "lssvr" else ["C", "epsilon", "gamma"]
    row = table.iloc[0]
    best_params, best_mse = {name: float(row[name]) for name in names}, float(row["mse"])
    if bounds is None:
        bounds = {name: (float(candidates[name].min()), float(candidates[name].max()))
                  for name in names if candidates[name].nunique() > 1}
    result = SearchResult(method, model, best_params, best_mse, table, elapsed_s, mse.size,
                          convergence_mse, bounds)
    warn_on_edges(result)
    return result
