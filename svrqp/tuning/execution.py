"""How a search runs: its folds, the solver of every fit, and where the fits run.

**Parallelism.** The fold × candidate evaluations go through joblib: ``backend="loky"`` (local
processes) or ``backend="dask"`` with a ``dask.distributed`` scheduler address (or ``Client``),
which spreads them over a cluster through joblib's Dask backend. Results do not depend on the
backend: each evaluation is deterministic and results are gathered by key, not by arrival order.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import joblib
from numpy.typing import ArrayLike

from svrqp.exceptions import ProblemError
from svrqp.extras import require

JOBLIB_BACKENDS: tuple[str, ...] = ("sequential", "loky", "threading", "dask")

#: Progress callback: ``progress(done, total)``.
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class Execution:
    """How a search scores and runs its candidates, the same for :func:`~svrqp.tuning.grid_search`
    and :func:`~svrqp.tuning.ga_search`.

    Attributes
    ----------
    cv : int or scikit-learn splitter, default=5
        Number of folds (``KFold`` without shuffling, as ``GridSearchCV``) or a splitter.
    groups : array-like, optional
        Group labels for group-aware splitters (e.g. ``GroupKFold``).
    solver : str, default="auto"
        ``"auto"`` or ``"dual_ipm"`` (the fast exact path on shared Gram matrices, see
        :func:`svrqp.solvers.epsilon_svr.fit_on_gram`) or the QP backend of the ε-SVR fits.
    tol : float, default=1e-8
        Solver accuracy (as :class:`~svrqp.EpsilonSVR`).
    backend : {"loky", "sequential", "threading", "dask"}
        joblib backend of the fold × candidate evaluations.
    n_jobs : int, optional
        joblib workers (default: 1 locally, every worker on Dask).
    scheduler : str or distributed.Client, optional
        Dask scheduler (address ``tcp://host:8786`` or a client) for ``backend="dask"``.
    progress : callable, optional
        ``progress(done, total)``: after each evaluated (fold, γ, ε) chain of a grid search,
        after each generation of the genetic algorithm.

    Raises
    ------
    ProblemError
        An unknown backend, or ``backend="dask"`` without a scheduler.
    """

    cv: int | Any = 5
    groups: ArrayLike | None = None
    solver: str = "auto"
    tol: float = 1e-8
    backend: str = "loky"
    n_jobs: int | None = None
    scheduler: Any = None
    progress: Progress | None = None

    def __post_init__(self) -> None:
        if self.backend not in JOBLIB_BACKENDS:
            raise ProblemError(f"backend must be one of {JOBLIB_BACKENDS}, got {self.backend!r}")
        if self.backend == "dask" and self.scheduler is None:
            raise ProblemError("backend='dask' needs a scheduler: its address (tcp://host:8786) or "
                               "a distributed.Client")

    @contextmanager
    def parallel(self) -> Iterator[None]:
        """Configure joblib for :attr:`backend`; for Dask,
        connect to :attr:`scheduler` (address or Client)."""
        if self.backend != "dask":
            with joblib.parallel_config(backend=self.backend, n_jobs=self.n_jobs):
                yield
            return
        require("dask", "a search on Dask")
        from distributed import Client

        client = self.scheduler if isinstance(self.scheduler, Client) else Client(self.scheduler)
        try:
            with joblib.parallel_config(backend="dask",
                                        n_jobs=-1 if self.n_jobs is None else self.n_jobs):
                yield
        finally:
            if client is not self.scheduler:
                client.close()
