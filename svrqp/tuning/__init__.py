"""Hyper-parameter search: k-fold cross-validated grid and a genetic algorithm (:mod:`~svrqp.tuning.search`)."""

from svrqp.tuning.search import (
    SearchResult,
    ga_search,
    grid_search,
    plot_convergence,
    plot_grid_scores,
)

__all__ = ["SearchResult", "ga_search", "grid_search", "plot_convergence", "plot_grid_scores"]
