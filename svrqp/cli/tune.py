"""``svrqp tune``: k-fold CV grid or GA search of (C, ε, γ) on a table, locally or on Dask."""

from __future__ import annotations

import json
import math
import warnings
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from svrqp import output, registry
from svrqp.cli._common import (
    SOLVER_HELP,
    TunableModel,
    model_option,
    read_table,
    select_train_rows,
    split_columns,
)
from svrqp.exceptions import ProblemError

if TYPE_CHECKING:
    from svrqp.tuning.execution import Execution
    from svrqp.tuning.result import SearchResult


class Method(str, Enum):
    grid = "grid"
    ga = "ga"


class Backend(str, Enum):
    loky = "loky"
    sequential = "sequential"
    dask = "dask"


#: Defaults per method: grid values, or (low, high) ranges for the GA.
DEFAULTS = {
    Method.grid: {"C": "1,10,100,1000", "gamma": "0.01,0.1,1,10", "epsilon": "0.01,0.1"},
    Method.ga: {"C": "0.1,100000", "gamma": "scale", "epsilon": "0.001,1"},
}


def _numbers(text: str, option: str) -> list[float]:
    try:
        return [float(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise ProblemError(f"{option}: expected comma-separated numbers, got {text!r}") from None


def _finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _report(result: SearchResult, folds: int) -> dict:
    records = [{key: (_finite_or_none(value) if isinstance(value, float) else value)
                for key, value in row.items()}
               for row in result.table.to_dict(orient="records")]
    return {
        "schema": "svrqp.tune/1",
        "method": result.method,
        "model": result.model,
        "folds": folds,
        "best_params": result.best_params,
        "best_mse": result.best_mse,
        "elapsed_s": result.elapsed_s,
        "n_fits": result.n_fits,
        "candidates": records,
        "convergence_mse": None if result.convergence_mse is None
        else result.convergence_mse.tolist(),
        "bounds": {name: list(bound) for name, bound in result.bounds.items()},
        "on_edge": result.edges(),
    }


def _print_result(console: Console, result: SearchResult, rows: int = 10) -> None:
    table = Table(title=f"{result.method} search, {result.model}: best {rows} of "
                        f"{len(result.table)} candidates")
    columns = [name for name in ("C", "epsilon", "gamma", "generation", "mse", "mse_std",
                                 "failed_folds")
               if name in result.table.columns]
    for name in columns:
        table.add_column(name, justify="right")
    for _, row in result.table.head(rows).iterrows():
        table.add_row(*(f"{row[name]:.5g}" if isinstance(row[name], float) else str(row[name])
                        for name in columns))
    console.print(table)
    best = ", ".join(f"{name} = {value:.6g}" for name, value in result.best_params.items())
    console.print(f"best: {best}  (CV MSE {result.best_mse:.6g}; {result.n_fits} fits in "
                  f"{result.elapsed_s:.2f} s)")


def tune(
    data: Path = typer.Argument(..., help="CSV or Parquet table with the target and feature "
                                          "columns."),
    target: str = typer.Option(..., "--target", help="Column to predict (e.g. error_um)."),
    features: str = typer.Option(..., "--features", help="Comma-separated input columns (e.g. "
                                                         "T7,T9)."),
    model: TunableModel = model_option(TunableModel, registry.tunable()[0],
                              "The ε-SVR tunes C, ε and γ; the LS-SVR C and γ."),
    train: str = typer.Option(None, "--train", help="Filter selecting the rows to tune on (e.g. "
                              "\"batch == 'x1'\"; see svrqp.query). Default: all rows."),
    method: Method = typer.Option(Method.grid, "--method", help="grid: k-fold CV over every "
                                  "combination; ga: the genetic algorithm of S1."),
    C: str = typer.Option(None, "--C", help="grid: comma-separated values; ga: low,high range. "
                          "Defaults: grid 1,10,100,1000; ga 0.1,100000."),
    gamma: str = typer.Option(None, "--gamma", help="RBF γ in exp(-γ‖x−x'‖²), in 1/(feature "
                              "unit)²; grid: values, ga: one value (fixed, as S1) or low,high "
                              "(tuned). Defaults: grid 0.01,0.1,1,10; ga fixed at scikit-learn's "
                              "'scale'."),
    epsilon: str = typer.Option(None, "--epsilon", help="ε-tube half-width in target units (svr "
                                                        "only); grid: values, "
                                "ga: low,high. Defaults: grid 0.01,0.1; ga 0.001,1."),
    folds: int = typer.Option(5, "--folds", help="Number of cross-validation folds (S0, S2: 5)."),
    shuffle: bool = typer.Option(False, "--shuffle/--no-shuffle", help="Shuffle rows before "
                                                                       "splitting into folds "
                                 "(default: contiguous folds, honest for time series)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the fold shuffle and of the GA."),
    population: int = typer.Option(100, "--population", help="GA population size (S1: 100)."),
    generations: int = typer.Option(50, "--generations", help="GA generations (S1: 50)."),
    solver: str = typer.Option("auto", "--solver", help=SOLVER_HELP + " 'dual_ipm' also "
                               "warm-starts along the C grid."),
    tol: float = typer.Option(1e-8, "--tol", help="Solver accuracy of every fit."),
    backend: Backend = typer.Option(Backend.loky, "--backend", help="Where the fold × candidate "
                                    "fits run: local processes (loky), in this process "
                                    "(sequential), or a Dask cluster (dask)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Dask scheduler address, e.g. "
                                  "tcp://10.0.0.5:8786 (with --backend dask)."),
    jobs: int = typer.Option(None, "--jobs", help="Parallel workers (default: 1 locally, all "
                                                  "workers on Dask)."),
    plot: Path = typer.Option(None, "--plot", help="Write the score plot (grid) or convergence "
                                                   "curve (ga) to this PNG."),
    json_path: Path = typer.Option(None, "--json", help="Write best parameters and every "
                                                        "candidate's score as JSON."),
    target_unit: str = typer.Option("target unit", "--target-unit", help="Unit of the target, for "
                                                                         "plot labels (e.g. μm)."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing --plot/--json files."),
) -> None:
    """Choose (C, ε, γ) by k-fold cross-validated MSE:
    a grid (S0, S2) or a genetic algorithm (S1)."""
    model = model.value
    from sklearn.model_selection import (
        KFold,  # imported when the command runs: `--help` stays quick
    )

    from svrqp.tuning import (  # matplotlib: not for --help
        Execution,
        SearchEdgeWarning,
        plot_convergence,
        plot_grid_scores,
    )

    for path in (plot, json_path):  # refused before the search, not after it
        if path is not None:
            output.check_target(path, force=force)
    X, y = _data(data, target, features, train)
    texts = {name: given or DEFAULTS[method][name]
             for name, given in (("C", C), ("gamma", gamma), ("epsilon", epsilon))}
    values = {name: [] if text == "scale" else _numbers(text, f"--{name}")
              for name, text in texts.items()}
    cv = KFold(folds, shuffle=True, random_state=seed) if shuffle else folds
    console = Console(stderr=True)
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as progress:
        task = progress.add_task("generations" if method == Method.ga else "fold fits", total=None)
        execution = Execution(cv=cv, solver=solver, tol=tol, backend=backend.value, n_jobs=jobs,
                              scheduler=scheduler, progress=lambda done,
                              total: progress.update(task, completed=done, total=total))
        genetic = {"population": population, "generations": generations, "seed": seed}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", SearchEdgeWarning)
            result = _search(method, model, X, y, values, genetic, execution)
    for warning in caught:  # one plain line each, not Python's warning format
        if issubclass(warning.category, SearchEdgeWarning):
            console.print(f"[yellow]warning:[/] {warning.message}")
    _print_result(Console(), result)
    if plot is not None:
        figure = (
            plot_grid_scores(result, target_unit)
            if method == Method.grid
            else plot_convergence(result, target_unit)
        )
        with output.replacing(plot, force=force) as temporary:
            figure.savefig(temporary, dpi=150)
        console.print(f"plot written to {plot}")
    if json_path is not None:
        output.write_text(json_path, json.dumps(_report(result, folds), indent=2), force=force)
        console.print(f"results written to {json_path}")


def _data(data: Path, target: str, features: str,
          train: str | None) -> tuple[np.ndarray, np.ndarray]:
    """The feature matrix and the target of the ``--train`` rows of the table ``data``."""
    table = read_table(data)
    table = table[select_train_rows(table, train)]
    names = split_columns(features, table, "--features", numeric=True)
    if not names:
        raise ProblemError("--features: give at least one column")
    split_columns(target, table, "--target", numeric=True)
    return table[names].to_numpy(dtype=float), table[target].to_numpy(dtype=float)


def _search(method: Method, model: str, X: np.ndarray, y: np.ndarray,
            values: dict[str, list[float]],
            genetic: dict[str, int], execution: Execution) -> SearchResult:
    """Run the grid or the GA on the values given for C, γ and ε (grid values, or GA ranges)."""
    from svrqp.tuning import Genetic, ga_search, grid_search

    if method == Method.grid:
        return grid_search(X, y, C=values["C"], gamma=values["gamma"], epsilon=values["epsilon"],
                           model=model, execution=execution)
    gammas = values["gamma"]  # none: 'scale'; one: fixed; two: a range to tune
    return ga_search(X, y, C_range=values["C"], epsilon_range=values["epsilon"],
                     gamma=gammas[0] if len(gammas) == 1 else (gammas or "scale"), model=model,
                     genetic=Genetic(**genetic), execution=execution)


def register(app: typer.Typer) -> None:
    """Add ``svrqp tune`` to the command."""
    app.command("tune")(tune)
