"""k-fold cross-validated grid search over (C, ε, γ) (S0, S2), with shared Gram matrices."""

from __future__ import annotations

import time

import pandas as pd
from numpy.typing import ArrayLike
from sklearn.model_selection import ParameterGrid

from svrqp.solvers.epsilon_svr import gram_solver, warm_start_applies
from svrqp.tuning.checks import check_model, grid_values, validated
from svrqp.tuning.cv import FitSettings, cv_mse, folds, scored_result
from svrqp.tuning.execution import Execution
from svrqp.tuning.result import SearchResult


def grid_search(
    X: ArrayLike,
    y: ArrayLike,
    *,
    C: ArrayLike,
    gamma: ArrayLike,
    epsilon: ArrayLike = (0.1,),
    model: str = "svr",
    warm_start: bool = True,
    execution: Execution | None = None,
) -> SearchResult:
    """k-fold cross-validated grid search over (C, ε, γ) with shared Gram matrices (RBF kernel).

    The same scores as ``GridSearchCV(EpsilonSVR(), {"C", "epsilon", "gamma"}, cv=cv,
    scoring="neg_mean_squared_error")`` (or ``LSSVR`` over ``{"C", "gamma"}``), with the Gram
    matrix computed once per γ instead of once per fit.

    Parameters
    ----------
    X : array-like of shape (n_samples, n_features)
    y : array-like of shape (n_samples,)
    C, gamma : array-like
        Grid values (positive); ``gamma`` in scikit-learn's convention ``exp(-gamma‖x−x'‖²)``.
    epsilon : array-like, default=(0.1,)
        Tube half-widths (non-negative, units of ``y``); ignored for ``model="lssvr"``.
    model : {"svr", "lssvr"}
    warm_start : bool, default=True
        Warm-start along the C grid (``dual_ipm`` and
        :data:`~svrqp.solvers.epsilon_svr.WARM_START_BACKENDS`).
    execution : Execution, optional
        The folds (``cv``, ``groups``), the solver and its ``tol``, and where the fits run
        (joblib ``backend``, ``n_jobs``, Dask ``scheduler``); its ``progress(done, total)`` is
        called after each evaluated (fold, γ, ε) chain. Default: ``Execution()``.

    Returns
    -------
    SearchResult

    Raises
    ------
    ProblemError
        Empty grid, a non-positive C or γ, a negative ε, bad folds, unknown model or solver.
    """
    execution = Execution() if execution is None else execution
    check_model(model)
    X, y = validated(X, y)
    grid = {"C": grid_values(C, "C"), "gamma": grid_values(gamma, "gamma")}
    solver = execution.solver
    if model == "svr":
        grid["epsilon"] = grid_values(epsilon, "epsilon", allow_zero=True)
        solver = gram_solver(solver)
    candidates = pd.DataFrame(list(ParameterGrid(grid)))[
        ["C", "epsilon", "gamma"] if model == "svr" else ["C", "gamma"]
    ]
    splits = folds(execution.cv, X, y, execution.groups)
    start = time.perf_counter()
    with execution.parallel():
        fit = FitSettings(model, solver, execution.tol, warm_start and warm_start_applies(solver))
        mse = cv_mse(X, y, candidates, splits, fit, execution.progress)
    return scored_result("grid", model, candidates, mse, time.perf_counter() - start)
