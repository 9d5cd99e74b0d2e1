"""Figures of a search result (object-oriented matplotlib: no pyplot state, no display needed)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from svrqp.exceptions import ProblemError
from svrqp.tuning.result import SearchResult


def plot_convergence(result: SearchResult, target_unit: str = "target unit") -> Figure:
    """Best CV MSE per generation of a GA search (S1 Fig. 4)."""
    if result.convergence_mse is None:
        raise ProblemError("plot_convergence needs a GA search result (method='ga')")
    figure = Figure(figsize=(6.0, 3.6), layout="constrained")
    axes = figure.add_subplot()
    axes.plot(np.arange(result.convergence_mse.size), result.convergence_mse, marker=".")
    axes.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes.set_xlabel("generation (-)")
    axes.set_ylabel(f"best CV MSE ({target_unit}²)")
    axes.set_title("GA convergence: " + ", ".join(f"{k} = {v:.4g}"
                                                  for k, v in result.best_params.items()))
    axes.grid(True, alpha=0.3)
    return figure


def plot_grid_scores(result: SearchResult, target_unit: str = "target unit") -> Figure:
    """CV MSE against C (log axes), one line per γ, at the best ε — the grid's score surface."""
    if result.method != "grid":
        raise ProblemError("plot_grid_scores needs a grid search result (method='grid')")
    table = result.table
    if result.model == "svr":
        table = table[table["epsilon"] == result.best_params["epsilon"]]
    figure = Figure(figsize=(6.0, 3.6), layout="constrained")
    axes = figure.add_subplot()
    for gamma, rows in table.sort_values("C").groupby("gamma"):
        axes.plot(rows["C"], rows["mse"], marker="o", label=f"γ = {gamma:.4g}")
    best = result.best_params
    axes.plot(best["C"], result.best_mse, marker="*", markersize=14, color="black",
              linestyle="none", label="best")
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("C (-)")
    axes.set_ylabel(f"CV MSE ({target_unit}²)")
    title = "k-fold CV score" + (f" at ε = {best['epsilon']:.4g} {target_unit}"
                                 if "epsilon" in best else "")
    axes.set_title(title)
    axes.legend(fontsize="small")
    axes.grid(True, which="both", alpha=0.3)
    return figure
