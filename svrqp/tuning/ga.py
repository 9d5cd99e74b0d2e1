r"""Genetic-algorithm search of S1 over (log C, log ε), fitness = −CV MSE, on pygad.

**Genetic algorithm** (S1, on `pygad <https://pygad.readthedocs.io>`_): real-coded individuals
:math:`(\log_{10} C, \log_{10}\varepsilon)` inside given ranges with the RBF :math:`\gamma` fixed,
as S1 tunes C and ε only (:math:`\log_{10}\gamma` becomes a third gene on request), population 100,
crossover probability 0.85, mutation probability 0.02 (a mutated gene is redrawn uniformly in
its range), rank selection, 50 generations, fitness :math:`-\operatorname{CV}(\theta)`
(:mod:`svrqp.tuning.cv`), one elite kept per generation; seeded, so a run is reproducible.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from svrqp.exceptions import ProblemError
from svrqp.extras import require
from svrqp.solvers.epsilon_svr import gram_solver
from svrqp.tuning.checks import (
    check_model,
    fixed_gamma,
    log_range,
    validated,
)
from svrqp.tuning.cv import FitSettings, cv_mse, folds, scored_result
from svrqp.tuning.execution import Execution
from svrqp.tuning.result import SearchResult


@dataclass(frozen=True)
class Genetic:
    """How the genetic algorithm searches: S1's population, generations and operators, and its seed.

    Attributes
    ----------
    population, generations : int
        S1: 100 and 50. Small values make quick runs (tests, notebooks).
    crossover_probability, mutation_probability : float
        S1: 0.85 and 0.02 (per gene).
    seed : int
        Seed of the GA's own random generators: the same seed gives the same search.

    Raises
    ------
    ProblemError
        ``population < 2``, ``generations < 1``, or a probability outside [0, 1].
    """

    population: int = 100
    generations: int = 50
    crossover_probability: float = 0.85
    mutation_probability: float = 0.02
    seed: int = 0

    def __post_init__(self) -> None:
        if self.population < 2 or self.generations < 1:
            raise ProblemError(f"need population >= 2 and generations >= 1, got {self.population} "
                               f"and {self.generations}")
        for name in ("crossover_probability", "mutation_probability"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ProblemError(f"{name} must be in [0, 1], got {getattr(self, name)}")


def ga_search(
    X: ArrayLike,
    y: ArrayLike,
    *,
    C_range: Sequence[float] = (1e-1, 1e5),
    epsilon_range: Sequence[float] = (1e-3, 1.0),
    gamma: float | str | Sequence[float] = "scale",
    model: str = "svr",
    genetic: Genetic = Genetic(),
    execution: Execution | None = None,
) -> SearchResult:
    """Genetic-algorithm search of S1 over (log C, log ε), fitness = −CV MSE (pygad).

    S1 tunes C and ε of an RBF ε-SVR; the kernel width stays fixed at ``gamma``. Given a
    ``(low, high)`` range as ``gamma``, γ becomes a third gene (an extension beyond S1).

    Parameters
    ----------
    X, y
        Training data.
    C_range, epsilon_range : (low, high)
        Search ranges, ``0 < low < high`` (genes are their base-10 logarithms);
        ``epsilon_range`` is ignored for ``model="lssvr"``.
    gamma : float, "scale" or (low, high)
        The fixed RBF γ (scikit-learn's convention ``exp(-γ‖x−x'‖²)``); ``"scale"`` is
        scikit-learn's and libsvm's default ``1 / (n_features · Var(X))``. A ``(low, high)``
        range tunes γ too, inside it (off by default, as in S1).
    model : {"svr", "lssvr"}
    genetic : Genetic, default=Genetic()
        Population, generations, crossover and mutation probabilities, seed (S1's by default).
    execution : Execution, optional
        As for :func:`~svrqp.tuning.grid_search` (default ``Execution()``); its
        ``progress(generation, generations)`` is called after each generation.

    Returns
    -------
    SearchResult
        With ``convergence_mse`` (best CV MSE per generation) and every evaluated candidate.
    """
    pygad = _pygad()
    execution = Execution() if execution is None else execution
    check_model(model)
    X, y = validated(X, y)
    names, gene_space, fixed = _genes(model,
                                      {"C": C_range, "epsilon": epsilon_range, "gamma": gamma}, X)
    solver = gram_solver(execution.solver) if model == "svr" else execution.solver
    splits = folds(execution.cv, X, y, execution.groups)
    # a generation's candidates are no C chains
    fit = FitSettings(model, solver, execution.tol, warm_start=False)
    evaluated: dict[tuple[float, ...], tuple[NDArray, int]] = {}  # genes -> (fold MSE, generation)

    def fitness(ga: Any, solutions: NDArray, _indices) -> list[float]:
        rows = [tuple(map(float, genes)) for genes in np.atleast_2d(solutions)]
        # GA repeats itself
        fresh = [genes for genes in dict.fromkeys(rows) if genes not in evaluated]
        if fresh:
            candidates = pd.DataFrame(10.0 ** np.array(fresh), columns=names).assign(**fixed)
            mse = cv_mse(X, y, candidates, splits, fit, None)
            for column, genes in enumerate(fresh):
                evaluated[genes] = (mse[:, column], ga.generations_completed)
        return [-_mean_or_inf(evaluated[genes][0]) for genes in rows]

    progress = execution.progress
    on_generation = None if progress is None else lambda ga: progress(ga.generations_completed,
                                                                      genetic.generations)
    ga = _algorithm(pygad, genetic, gene_space, fitness, on_generation)
    start = time.perf_counter()
    with execution.parallel():
        ga.run()
    elapsed_s = time.perf_counter() - start
    genes = list(evaluated)
    candidates = pd.DataFrame(10.0 ** np.array(genes), columns=names).assign(**fixed)
    candidates = candidates[[*(["C", "epsilon"] if model == "svr" else ["C"]), "gamma"]]
    candidates["generation"] = [evaluated[g][1] for g in genes]
    bounds = {name: (10.0 ** space["low"], 10.0 ** space["high"])
              for name, space in zip(names, gene_space, strict=True)}
    return scored_result("ga", model, candidates, np.column_stack([evaluated[g][0] for g in genes]),
                         elapsed_s,
                         convergence_mse=-np.asarray(ga.best_solutions_fitness, dtype=float),
                         bounds=bounds)


def _pygad() -> Any:
    require("ga", "the genetic algorithm")
    import pygad

    return pygad


def _genes(model: str, ranges: dict[str, Any],
           X: NDArray) -> tuple[list[str], list[dict[str, float]], dict[str, float]]:
    """Names of the genes, their ``{"low", "high"}``
    log10 ranges, and the parameters held fixed (γ)."""
    names = ["C", "epsilon"] if model == "svr" else ["C"]
    fixed = {}
    if isinstance(ranges["gamma"], str) or np.ndim(ranges["gamma"]) == 0:
        fixed["gamma"] = fixed_gamma(ranges["gamma"], X)
    else:
        names.append("gamma")
    gene_space = [dict(zip(("low", "high"), log_range(ranges[name], name), strict=False))
                  for name in names]
    return names, gene_space, fixed


def _algorithm(pygad: Any, genetic: Genetic, gene_space: list[dict[str, float]], fitness: Callable,
               on_generation: Callable | None) -> Any:
    """S1's algorithm as a ``pygad.GA``: rank selection, single-point crossover, one elite."""
    return pygad.GA(
        num_generations=genetic.generations,
        num_parents_mating=max(2, genetic.population // 2),
        fitness_func=fitness,
        fitness_batch_size=genetic.population,
        sol_per_pop=genetic.population,
        num_genes=len(gene_space),
        gene_space=gene_space,
        parent_selection_type="rank",
        crossover_type="single_point",
        crossover_probability=genetic.crossover_probability,
        mutation_type="random",
        mutation_probability=genetic.mutation_probability,
        mutation_by_replacement=True,
        keep_elitism=1,
        random_seed=genetic.seed,
        suppress_warnings=True,
        on_generation=on_generation,
    )


def _mean_or_inf(fold_mse: NDArray) -> float:
    return float(fold_mse.mean()) if np.all(np.isfinite(fold_mse)) else np.inf
