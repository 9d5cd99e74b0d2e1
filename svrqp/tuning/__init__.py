"""Hyper-parameter search: k-fold cross-validated grid (S0, S2) and a genetic algorithm (S1).

- :mod:`~svrqp.tuning.grid`: :func:`grid_search` over (C, ε, γ);
- :mod:`~svrqp.tuning.ga`: :func:`ga_search`, S1's genetic algorithm, set up by :class:`Genetic`;
- :mod:`~svrqp.tuning.execution`: :class:`Execution`,
  how either search runs (folds, solver, joblib/Dask);
- :mod:`~svrqp.tuning.cv`: the cross-validation score on shared Gram matrices, each fit by
  :func:`svrqp.solvers.epsilon_svr.fit_on_gram` (warm-started along the C grid);
- :mod:`~svrqp.tuning.result`: :class:`SearchResult`; :mod:`~svrqp.tuning.plots`: its figures.
"""

from svrqp.tuning.execution import Execution
from svrqp.tuning.ga import Genetic, ga_search
from svrqp.tuning.grid import grid_search
from svrqp.tuning.plots import plot_convergence, plot_grid_scores
from svrqp.tuning.result import SearchEdgeWarning, SearchResult

__all__ = ["Execution", "Genetic", "SearchEdgeWarning", "SearchResult", "ga_search", "grid_search",
           "plot_convergence", "plot_grid_scores"]
