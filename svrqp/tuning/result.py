"""The outcome of a hyper-parameter search, shared by the grid and the genetic algorithm."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from svrqp import registry
from svrqp.estimators.kernel import LSSVR, EpsilonSVR

#: A best value within this share of the searched range's log-span from an end is "on the edge".
EDGE_SHARE = 0.01


class SearchEdgeWarning(UserWarning):
    """A search ended on the edge of its range: the optimum may lie beyond it."""


def warn_on_edges(result: SearchResult) -> None:
    """Warn (:class:`SearchEdgeWarning`) when ``result`` ended on the edge of a searched range."""
    text = result.edge_text()
    if text:
        warnings.warn(SearchEdgeWarning(text), stacklevel=4)  # the caller of the search


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
    bounds : dict
        The searched range ``(low, high)`` of each tuned parameter: the grid's smallest and
        largest value, or the GA's range. A parameter held fixed has none.
    """

    method: str
    model: str
    best_params: dict[str, float]
    best_mse: float
    table: pd.DataFrame
    elapsed_s: float
    n_fits: int
    convergence_mse: NDArray[np.float64] | None = None
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)

    def edges(self) -> dict[str, str]:
        """Tuned parameters whose best value lies on the edge of the searched range.

        Returns
        -------
        dict
            Parameter name -> ``"lower"`` or ``"upper"``: the best value is within
            :data:`EDGE_SHARE` of the range's logarithmic span from that end (for a grid: it is
            the smallest or the largest value). The optimum may lie beyond it; widen the range.
        """
        edges = {}
        for name, (low, high) in self.bounds.items():
            span = math.log10(high / low)
            where = math.log10(self.best_params[name] / low)
            if where <= EDGE_SHARE * span:
                edges[name] = "lower"
            elif where >= (1.0 - EDGE_SHARE) * span:
                edges[name] = "upper"
        return edges

    def edge_text(self) -> str:
        """One sentence naming each parameter that ended on an edge (empty when none did)."""
        parts = [f"{name} = {self.best_params[name]:.4g} on the {side} edge of the searched range "
                 f"[{self.bounds[name][0]:.4g}, {self.bounds[name][1]:.4g}]"
                 for name, side in self.edges().items()]
        if not parts:
            return ""
        return (f"the search ended with {'; '.join(parts)}: the optimum may lie beyond it, "
                "widen the range")

    def best_estimator(self, **estimator_params: Any) -> EpsilonSVR | LSSVR:
        """An unfitted estimator with the best parameters
        (RBF kernel), e.g. to refit on all data."""
        return registry.spec(self.model).estimator_class()(kernel="rbf", **self.best_params,
                                                           **estimator_params)
