r"""Hyper-parameter search: k-fold cross-validated grid (S0, S2) and a genetic algorithm (S1).

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
fold are slices of it, and every :math:`(C, \varepsilon)` of that fold reuses them. Along the
C grid (ascending) the ε-SVR dual of the previous C is a feasible starting point of the next one
(the box :math:`[-C, C]` only grows), so backends that accept a warm start
(:data:`WARM_START_BACKENDS`) get it.

**The fast exact path** (``solver="dual_ipm"``, and the default ``"auto"``): each fit is the exact optimum of
:func:`svrqp.solvers.dual_ipm.exact.solve_exact` (interior point on the reduced system, then an active-set
crossover). Along the C grid the previous optimum's active set — which coefficients are zero,
free, or at the bound (moved from :math:`\pm C_{prev}` to :math:`\pm C`) — starts the crossover at
the next C directly; if :data:`WARM_CROSSOVER_STEPS` primal–dual active-set steps do not reach a
point that satisfies every KKT condition, the fit falls back to the interior point. Either way
the returned coefficients satisfy the KKT conditions to rounding (checked again here, not taken
from the crossover) or are the converged interior-point solution; a fit that is neither counts
as failed.

**Genetic algorithm** (S1, on `pygad <https://pygad.readthedocs.io>`_): real-coded individuals
:math:`(\log_{10} C, \log_{10}\varepsilon)` inside given ranges with the RBF :math:`\gamma` fixed, as
S1 tunes C and ε only (:math:`\log_{10}\gamma` becomes a third gene on request), population 100,
crossover probability 0.85, mutation probability 0.02 (a mutated gene is redrawn uniformly in
its range), rank selection, 50 generations, fitness :math:`-\operatorname{CV}(\theta)`, one elite
kept per generation; seeded, so a run is reproducible.

**Parallelism.** The fold × candidate evaluations go through joblib: ``backend="loky"`` (local
processes) or ``backend="dask"`` with a ``dask.distributed`` scheduler address (or ``Client``),
which spreads them over a cluster through joblib's Dask backend. Results do not depend on the
backend: each evaluation is deterministic and results are gathered by key, not by arrival order.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import joblib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from numpy.typing import ArrayLike, NDArray
from sklearn.model_selection import KFold, ParameterGrid, check_cv
from sklearn.utils.validation import check_X_y

from svrqp.solvers import dual_ipm
from svrqp.estimators.kernel import DUAL_IPM, LSSVR, EpsilonSVR
from svrqp.exceptions import BackendNotAvailableError, ProblemError, SolverError
from svrqp.formulations import epsilon_svr, epsilon_svr_certificate, ls_svr
from svrqp.kernels import gram
from svrqp.solvers.qp_backends import require_backend
from svrqp.solvers.auto import AUTO

MODELS: tuple[str, ...] = ("svr", "lssvr")
JOBLIB_BACKENDS: tuple[str, ...] = ("sequential", "loky", "threading", "dask")

#: Backends whose qpsolvers adapter uses ``initvals`` (first-order and augmented-Lagrangian
#: methods); interior-point backends ignore a warm start, so it is not passed to them.
WARM_START_BACKENDS = frozenset({"osqp", "proxqp", "qpalm", "scs"})

#: ``solver="dual_ipm"``: primal–dual active-set steps tried from the previous C's active set
#: before falling back to the interior point (measured on friedman1, n = 1600: a successful warm
#: start takes 1–14 steps; a failed attempt of this length costs about a quarter of a cold fit).
WARM_CROSSOVER_STEPS = 10

#: Progress callback: ``progress(done, total)``.
Progress = Callable[[int, int], None]


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
        estimator = EpsilonSVR if self.model == "svr" else LSSVR
        return estimator(kernel="rbf", **self.best_params, **estimator_params)


# --------------------------------------------------------------------------------------------
# Input checks


def _check_model(model: str) -> None:
    if model not in MODELS:
        raise ProblemError(f"model must be one of {MODELS}, got {model!r}")


def _check_solver(solver: str) -> str:
    """The solver the fits use: ``"auto"`` is the exact path on shared Gram matrices, ``dual_ipm``."""
    if solver == AUTO:
        return DUAL_IPM
    if solver != DUAL_IPM:
        require_backend(solver)
    return solver


def _grid_values(values: ArrayLike, name: str, *, allow_zero: bool = False) -> NDArray[np.float64]:
    values = np.unique(np.asarray(values, dtype=float).ravel())
    if values.size == 0:
        raise ProblemError(f"the {name} grid is empty: give at least one value")
    lowest_allowed = "non-negative" if allow_zero else "positive"
    if not np.all(np.isfinite(values)) or (values.min() < 0 if allow_zero else values.min() <= 0):
        raise ProblemError(f"every {name} must be finite and {lowest_allowed}, got {values.tolist()}")
    return values


def _log_range(bounds: Sequence[float], name: str) -> tuple[float, float]:
    if len(bounds) != 2:
        raise ProblemError(f"{name} range must be (low, high), got {tuple(bounds)}")
    low, high = float(bounds[0]), float(bounds[1])
    if not (np.isfinite(low) and np.isfinite(high) and 0 < low < high):
        raise ProblemError(f"{name} range must satisfy 0 < low < high (searched in log space), got ({low}, {high})")
    return np.log10(low), np.log10(high)


def _folds(cv: int | Any, X: NDArray, y: NDArray, groups: ArrayLike | None) -> list[tuple[NDArray, NDArray]]:
    if isinstance(cv, int | np.integer) and not 2 <= cv <= X.shape[0]:
        raise ProblemError(f"folds must be between 2 and n_samples = {X.shape[0]}, got {cv}")
    splitter = KFold(int(cv)) if isinstance(cv, int | np.integer) else check_cv(cv)
    return list(splitter.split(X, y, groups))


# --------------------------------------------------------------------------------------------
# One fold, one chain of C values


def _fit_epsilon_svr(
    K: NDArray, y: NDArray, C: float, epsilon: float, solver: str, tol: float, previous: Any
) -> tuple[NDArray, float, Any]:
    """β (zero off the support), b and what warm-starts the next C on a Gram matrix.

    ``previous`` is what the previous fit returned (``None``: a cold start): the raw QP solution
    for the QP backends, ``(β, C)`` for ``dual_ipm``.
    """
    if solver == DUAL_IPM:
        beta, b = _exact_dual_along_c(K, y, float(C), float(epsilon), tol, previous)
        return beta, b, (beta, float(C))
    beta, b, _, solution, _ = epsilon_svr.solve_dual(K, y, C, epsilon, solver, epsilon_svr.DualSettings(tol=tol),
                                                     initvals=previous)
    beta = np.where(epsilon_svr.support_mask(beta, C), beta, 0.0)
    return beta, b, solution.x


def _exact_dual_along_c(
    K: NDArray, y: NDArray, C: float, epsilon: float, tol: float, previous: tuple[NDArray, float] | None
) -> tuple[NDArray, float]:
    """The exact dual at C: the crossover from the previous C's active set, else the interior point."""
    if previous is not None:
        beta_previous, C_previous = previous
        at_bound = np.abs(beta_previous) >= C_previous * (1.0 - epsilon_svr.SV_TOLERANCE)
        guess = np.where(at_bound, np.sign(beta_previous) * C, beta_previous)  # same states, new box
        warm = dual_ipm.crossover(lambda idx: K[:, idx], y, C, epsilon, guess,
                                  settings=dual_ipm.CrossoverSettings(fast_steps=WARM_CROSSOVER_STEPS, max_steps=0))
        if warm.exact and _kkt_holds(K, y, warm.beta, warm.intercept, C, epsilon):
            return warm.beta, warm.intercept
    fit = dual_ipm.solve_exact(K, y, C, epsilon, tol=tol)
    if fit.crossover.exact and _kkt_holds(K, y, fit.crossover.beta, fit.crossover.intercept, C, epsilon):
        return fit.crossover.beta, fit.crossover.intercept
    if fit.ipm.converged:
        return fit.ipm.beta, fit.ipm.intercept
    raise SolverError(f"{DUAL_IPM!r} did not converge at C = {C:g} in {fit.ipm.iterations} iterations "
                      f"and its crossover did not reach the optimum", DUAL_IPM, "max_iter")


#: Slack of :func:`_kkt_holds`, relative to C·n (equality) and to 1 + max|y| (tube conditions):
#: ten times the crossover's own, so a different summation order cannot reject its optimum.
KKT_TOL = 1e-8


def _kkt_holds(K: NDArray, y: NDArray, beta: NDArray, b: float, C: float, epsilon: float) -> bool:
    r"""Every ε-SVR optimality condition at (β, b), checked here rather than trusted from the crossover.

    A warm start guessed from another C is far from the states the crossover was designed to
    start from (an interior point's), so its answer is re-checked from first principles: the
    equality :math:`\mathbf 1^\top\beta = 0`, the box, zeros inside the tube, free coefficients
    on it, bounded ones outside.
    """
    slack = KKT_TOL * (1.0 + float(np.max(np.abs(y))))
    if abs(float(beta.sum())) > KKT_TOL * C * beta.size or np.max(np.abs(beta)) > C:
        return False
    residual = epsilon_svr_certificate.multipliers(beta, b, K @ beta, y, epsilon).residual
    state = epsilon_svr_certificate.states(beta, C, 0.0)  # exactly 0 or exactly ±C
    return bool(np.all(epsilon_svr_certificate.kkt_violation(residual, state, epsilon) <= slack))


def _fold_chain(
    key: tuple[int, int],
    K_train: NDArray,
    y_train: NDArray,
    K_valid: NDArray,
    y_valid: NDArray,
    model: str,
    epsilon: float | None,
    Cs: NDArray,
    solver: str,
    tol: float,
    warm_start: bool,
) -> tuple[tuple[int, int], NDArray[np.float64]]:
    """Validation MSE of one fold for each C of ``Cs`` (ascending); ``inf`` where a fit failed.

    ``key`` is handed back with the result so results can be gathered in any arrival order.
    """
    mse = np.full(Cs.size, np.inf)
    previous = None
    for index, C in enumerate(Cs):
        try:
            if model == "svr":
                coef, b, previous = _fit_epsilon_svr(
                    K_train, y_train, C, epsilon, solver, tol, previous if warm_start else None)
            else:
                coef, b, _ = ls_svr.solve_cholesky_schur(K_train, y_train, C)
        except SolverError:
            previous = None  # do not warm-start from a failed solve
            continue
        mse[index] = np.mean((y_valid - (K_valid @ coef + b)) ** 2)
    return key, mse


# --------------------------------------------------------------------------------------------
# Evaluating a set of candidates over the folds, through joblib


@contextmanager
def _joblib_backend(backend: str, n_jobs: int | None, scheduler: Any) -> Iterator[None]:
    """Configure joblib for ``backend``; for Dask, connect to ``scheduler`` (address or Client)."""
    if backend not in JOBLIB_BACKENDS:
        raise ProblemError(f"backend must be one of {JOBLIB_BACKENDS}, got {backend!r}")
    if backend != "dask":
        with joblib.parallel_config(backend=backend, n_jobs=n_jobs):
            yield
        return
    if scheduler is None:
        raise ProblemError("backend='dask' needs a scheduler: its address (tcp://host:8786) or a distributed.Client")
    from distributed import Client

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    try:
        with joblib.parallel_config(backend="dask", n_jobs=-1 if n_jobs is None else n_jobs):
            yield
    finally:
        if client is not scheduler:
            client.close()


def _cv_mse(
    X: NDArray,
    y: NDArray,
    candidates: pd.DataFrame,
    model: str,
    folds: list[tuple[NDArray, NDArray]],
    solver: str,
    tol: float,
    warm_start: bool,
    progress: Progress | None,
) -> NDArray[np.float64]:
    """Validation MSE, shape (n_folds, n_candidates), of every candidate row (C, [epsilon,] gamma).

    The joblib backend must already be configured (see :func:`_joblib_backend`).
    """
    chain_keys = ["gamma"] if model == "lssvr" else ["gamma", "epsilon"]
    chains = [(key, rows.sort_values("C")) for key, rows in candidates.groupby(chain_keys, sort=True)]

    def tasks():
        K, K_gamma = None, None
        for chain_index, ((gamma, *epsilon), rows) in enumerate(chains):
            if gamma != K_gamma:  # chains are sorted by gamma: one Gram matrix per gamma
                K, K_gamma = gram(X, kernel="rbf", gamma=gamma), gamma
            for fold_index, (train, valid) in enumerate(folds):
                yield joblib.delayed(_fold_chain)(
                    (fold_index, chain_index), K[np.ix_(train, train)], y[train], K[np.ix_(valid, train)],
                    y[valid], model, epsilon[0] if epsilon else None, rows["C"].to_numpy(), solver, tol,
                    warm_start)

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
        raise SolverError("every candidate had at least one failed fit; try another solver or tolerance")
    finite = np.where(failed, 0.0, mse)
    table = candidates.copy()
    table["mse"] = np.where(failed.any(axis=0), np.inf, finite.mean(axis=0))
    table["mse_std"] = np.where(failed.any(axis=0), np.nan, finite.std(axis=0))
    table["failed_folds"] = failed.sum(axis=0)
    return table.sort_values("mse", kind="stable").reset_index(drop=True)


def _best(table: pd.DataFrame, model: str) -> tuple[dict[str, float], float]:
    names = ["C", "gamma"] if model == "lssvr" else ["C", "epsilon", "gamma"]
    row = table.iloc[0]
    return {name: float(row[name]) for name in names}, float(row["mse"])


def _validated(X: ArrayLike, y: ArrayLike) -> tuple[NDArray, NDArray]:
    try:
        return check_X_y(X, y, dtype=np.float64, y_numeric=True)
    except ValueError as err:
        raise ProblemError(f"X, y: {err}") from err


# --------------------------------------------------------------------------------------------
# Public searches


def grid_search(
    X: ArrayLike,
    y: ArrayLike,
    *,
    C: ArrayLike,
    gamma: ArrayLike,
    epsilon: ArrayLike = (0.1,),
    model: str = "svr",
    cv: int | Any = 5,
    groups: ArrayLike | None = None,
    solver: str = "auto",
    tol: float = 1e-8,
    warm_start: bool = True,
    backend: str = "loky",
    n_jobs: int | None = None,
    scheduler: Any = None,
    progress: Progress | None = None,
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
    cv : int or scikit-learn splitter, default=5
        Number of folds (``KFold`` without shuffling, as ``GridSearchCV``) or a splitter.
    groups : array-like, optional
        Group labels for group-aware splitters.
    solver : str, default="auto"
        ``"auto"`` or ``"dual_ipm"`` (the fast exact path on shared Gram matrices, see the module
        docstring) or the QP backend of the ε-SVR fits.
    tol : float, default=1e-8
        Solver accuracy (as :class:`~svrqp.EpsilonSVR`).
    warm_start : bool, default=True
        Warm-start along the C grid (``dual_ipm`` and :data:`WARM_START_BACKENDS`).
    backend : {"loky", "sequential", "threading", "dask"}
        joblib backend of the fold × candidate evaluations.
    n_jobs : int, optional
        joblib workers (default: 1 locally, every worker on Dask).
    scheduler : str or distributed.Client, optional
        Dask scheduler for ``backend="dask"``.
    progress : callable, optional
        ``progress(done, total)`` after each evaluated (fold, γ, ε) chain.

    Returns
    -------
    SearchResult

    Raises
    ------
    ProblemError
        Empty grid, a non-positive C or γ, a negative ε, bad folds, unknown model or backend.
    """
    _check_model(model)
    X, y = _validated(X, y)
    grid = {"C": _grid_values(C, "C"), "gamma": _grid_values(gamma, "gamma")}
    if model == "svr":
        grid["epsilon"] = _grid_values(epsilon, "epsilon", allow_zero=True)
        solver = _check_solver(solver)
    candidates = pd.DataFrame(list(ParameterGrid(grid)))[["C", "epsilon", "gamma"] if model == "svr" else ["C", "gamma"]]
    folds = _folds(cv, X, y, groups)
    start = time.perf_counter()
    with _joblib_backend(backend, n_jobs, scheduler):
        warm = warm_start and (solver == DUAL_IPM or solver in WARM_START_BACKENDS)
        mse = _cv_mse(X, y, candidates, model, folds, solver, tol, warm, progress)
    table = _scored_table(candidates, mse)
    best_params, best_mse = _best(table, model)
    return SearchResult("grid", model, best_params, best_mse, table, time.perf_counter() - start, mse.size)


def ga_search(
    X: ArrayLike,
    y: ArrayLike,
    *,
    C_range: Sequence[float] = (1e-1, 1e5),
    epsilon_range: Sequence[float] = (1e-3, 1.0),
    gamma: float | str = "scale",
    gamma_range: Sequence[float] | None = None,
    model: str = "svr",
    population: int = 100,
    generations: int = 50,
    crossover_probability: float = 0.85,
    mutation_probability: float = 0.02,
    seed: int = 0,
    cv: int | Any = 5,
    groups: ArrayLike | None = None,
    solver: str = "auto",
    tol: float = 1e-8,
    backend: str = "loky",
    n_jobs: int | None = None,
    scheduler: Any = None,
    progress: Progress | None = None,
) -> SearchResult:
    """Genetic-algorithm search of S1 over (log C, log ε), fitness = −CV MSE (pygad).

    S1 tunes C and ε of an RBF ε-SVR; the kernel width stays fixed at ``gamma``. Given a
    ``gamma_range``, γ becomes a third gene (an extension beyond S1).

    Parameters
    ----------
    X, y
        Training data.
    C_range, epsilon_range : (low, high)
        Search ranges, ``0 < low < high`` (genes are their base-10 logarithms);
        ``epsilon_range`` is ignored for ``model="lssvr"``.
    gamma : float or "scale"
        The fixed RBF γ (scikit-learn's convention ``exp(-γ‖x−x'‖²)``) when ``gamma_range`` is
        None; ``"scale"`` is scikit-learn's and libsvm's default ``1 / (n_features · Var(X))``.
    gamma_range : (low, high), optional
        Tune γ too, inside this range (off by default, as in S1).
    model : {"svr", "lssvr"}
    population, generations : int
        S1: 100 and 50. Small values make quick runs (tests, notebooks).
    crossover_probability, mutation_probability : float
        S1: 0.85 and 0.02 (per gene).
    seed : int
        Seed of the GA's own random generators: the same seed gives the same search.
    cv, groups, solver, tol, backend, n_jobs, scheduler
        As for :func:`grid_search`.
    progress : callable, optional
        ``progress(generation, generations)`` after each generation.

    Returns
    -------
    SearchResult
        With ``convergence_mse`` (best CV MSE per generation) and every evaluated candidate.
    """
    try:
        import pygad
    except ImportError as err:  # an optional extra, named like a missing solver backend
        raise BackendNotAvailableError("the genetic algorithm needs pygad; install it with: "
                                       "pip install 'svrqp[dist]'") from err
    _check_model(model)
    X, y = _validated(X, y)
    names = ["C", "epsilon"] if model == "svr" else ["C"]
    ranges = {"C": C_range, "epsilon": epsilon_range, "gamma": gamma_range}
    fixed = {}
    if gamma_range is None:
        fixed["gamma"] = _fixed_gamma(gamma, X)
    else:
        names.append("gamma")
    gene_space = [dict(zip(("low", "high"), _log_range(ranges[name], name))) for name in names]
    if population < 2 or generations < 1:
        raise ProblemError(f"need population >= 2 and generations >= 1, got {population} and {generations}")
    for name, p in (("crossover_probability", crossover_probability), ("mutation_probability", mutation_probability)):
        if not 0.0 <= p <= 1.0:
            raise ProblemError(f"{name} must be in [0, 1], got {p}")
    if model == "svr":
        solver = _check_solver(solver)
    folds = _folds(cv, X, y, groups)
    evaluated: dict[tuple[float, ...], tuple[NDArray, int]] = {}  # genes -> (fold MSE, generation)

    def fitness(ga: pygad.GA, solutions: NDArray, _indices) -> list[float]:
        rows = [tuple(map(float, genes)) for genes in np.atleast_2d(solutions)]
        fresh = [genes for genes in dict.fromkeys(rows) if genes not in evaluated]  # GA repeats itself
        if fresh:
            candidates = pd.DataFrame(10.0 ** np.array(fresh), columns=names).assign(**fixed)
            mse = _cv_mse(X, y, candidates, model, folds, solver, tol, False, None)
            for column, genes in enumerate(fresh):
                evaluated[genes] = (mse[:, column], ga.generations_completed)
        return [-_mean_or_inf(evaluated[genes][0]) for genes in rows]

    ga = pygad.GA(
        num_generations=generations,
        num_parents_mating=max(2, population // 2),
        fitness_func=fitness,
        fitness_batch_size=population,
        sol_per_pop=population,
        num_genes=len(names),
        gene_space=gene_space,
        parent_selection_type="rank",
        crossover_type="single_point",
        crossover_probability=crossover_probability,
        mutation_type="random",
        mutation_probability=mutation_probability,
        mutation_by_replacement=True,
        keep_elitism=1,
        random_seed=seed,
        suppress_warnings=True,
        on_generation=None if progress is None else lambda ga: progress(ga.generations_completed, generations),
    )
    start = time.perf_counter()
    with _joblib_backend(backend, n_jobs, scheduler):
        ga.run()
    elapsed_s = time.perf_counter() - start
    genes = list(evaluated)
    candidates = pd.DataFrame(10.0 ** np.array(genes), columns=names).assign(**fixed)
    candidates = candidates[[*(["C", "epsilon"] if model == "svr" else ["C"]), "gamma"]]
    candidates["generation"] = [evaluated[g][1] for g in genes]
    table = _scored_table(candidates, np.column_stack([evaluated[g][0] for g in genes]))
    best_params, best_mse = _best(table, model)
    return SearchResult("ga", model, best_params, best_mse, table, elapsed_s, len(genes) * len(folds),
                        convergence_mse=-np.asarray(ga.best_solutions_fitness, dtype=float))


def _fixed_gamma(gamma: float | str, X: NDArray) -> float:
    """The RBF γ held fixed by the GA: a positive number, or scikit-learn's ``"scale"``."""
    if isinstance(gamma, str):
        if gamma != "scale":
            raise ProblemError(f"gamma must be a positive number or 'scale', got {gamma!r}")
        variance = float(X.var())
        if not variance > 0:
            raise ProblemError("gamma='scale' needs features that vary (Var(X) is 0); give gamma explicitly")
        return 1.0 / (X.shape[1] * variance)
    if not (np.isfinite(gamma) and gamma > 0):
        raise ProblemError(f"gamma must be a positive number or 'scale', got {gamma!r}")
    return float(gamma)


def _mean_or_inf(fold_mse: NDArray) -> float:
    return float(fold_mse.mean()) if np.all(np.isfinite(fold_mse)) else np.inf


# --------------------------------------------------------------------------------------------
# Plots (object-oriented matplotlib: no pyplot state, no display needed)


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
    axes.set_title("GA convergence: " + ", ".join(f"{k} = {v:.4g}" for k, v in result.best_params.items()))
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
    axes.plot(best["C"], result.best_mse, marker="*", markersize=14, color="black", linestyle="none", label="best")
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("C (-)")
    axes.set_ylabel(f"CV MSE ({target_unit}²)")
    title = "k-fold CV score" + (f" at ε = {best['epsilon']:.4g} {target_unit}" if "epsilon" in best else "")
    axes.set_title(title)
    axes.legend(fontsize="small")
    axes.grid(True, which="both", alpha=0.3)
    return figure
