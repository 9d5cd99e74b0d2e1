"""The outcome of a hyper-parameter search, shared by the grid and the genetic algorithm."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from svrqp import registry
from svrqp.estimators.kernel import LSSVR, EpsilonSVR

@dataclass
class SearchResult:
    """Outcome of a hyper-parameter search.

    Attributes
    ----------
    method : {"grid", "ga"}
    model : {"svr", "lssvr"}
    best_params : dict
        ``{"C", "epsilon", "gamma"}`` (no ``"epsilon"`` for LS-SVR) of the lowest CV MSE.
    best_mse : float
        Its cross-validated mean squared error (units of the target, squared).
    table : pandas.DataFrame
        One row per evaluated candidate: the parameters, ``mse`` (mean over folds), ``mse_std``
        (standard deviation over folds), ``failed_folds`` (fits whose solver failed; their MSE
        is ``inf``), and for the GA ``generation`` (first generation that proposed it).
        Sorted by ``mse``.
    elapsed_s : float
        Wall-clock time of the search.
    n_fits : int
        Number of (candidate, fold) fits computed.
    convergence_mse : ndarray or None
        GA only: best CV MSE of the population after each generation (entry 0: the initial
        population) — the convergence curve of S1 Fig. 4.
    """

    method: str
    model: str
    best_params: dict[str, float]
    best_mse: float
    table: pd.DataFrame
    elapsed_s: float
    n_fits: int
    convergence_mse: NDArray[np.float64] | None = None

    def best_estimator(self, **estimator_params: Any) -> EpsilonSVR | LSSVR:
        """An unfitted estimator with the best parameters (RBF kernel), e.g. to refit on all data."""
        return registry.spec(self.model).estimator_class()(kernel="rbf", **self.best_params, **estimator_params)
