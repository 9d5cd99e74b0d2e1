"""The whole solver comparison: every backend × formulation × dataset × n is one row.

Each method (:mod:`svrqp.bench.runners`) runs in a child process that is killed at the per-run
time limit; a method that hit the limit at one n is not tried at larger n. Each run gives a
:class:`~svrqp.bench.outcomes.RunOutcome`; :func:`~svrqp.bench.evaluate.evaluate` turns it into
a row with the columns of :data:`~svrqp.bench.evaluate.ROW_COLUMNS`, comparing it with the
reference run of its problem (libsvm for ε-SVR, ``numpy.linalg.solve`` of S4 eq. (5) for LS-SVR).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import pandas as pd

from svrqp.bench.cases import PROFILES, make_case
from svrqp.bench.evaluate import ROW_COLUMNS, evaluate
from svrqp.bench.outcomes import Method, RunOutcome
from svrqp.bench.runners import REFERENCES, methods, run_isolated
from svrqp.exceptions import ProblemError
from svrqp.solvers.qp_backends import BACKENDS


@dataclass(frozen=True)
class BenchConfig:
    """What to run: datasets × sizes, and the methods compared on each."""

    datasets: tuple[str, ...] = ("friedman1",)
    sizes: tuple[int, ...] = (250, 500, 1000)
    d: int = 10
    kernel: str = "rbf"
    C: float = 10.0
    epsilon: float = 0.1
    gamma: float | str = "scale"
    formulations: tuple[str, ...] = ("stacked", "split")
    backends: tuple[str, ...] = ("clarabel", "osqp", "piqp", "proxqp", "highs")
    ls_svr: bool = False
    profile: str = "default"
    time_limit_s: float = 60.0
    shift_s: float = 1.0
    threads: int = 1
    seed: int = 0

    def __post_init__(self) -> None:
        if self.profile not in PROFILES:
            raise ProblemError(f"profile must be one of {sorted(PROFILES)}, got {self.profile!r}")
        if not self.sizes or min(self.sizes) < 2:
            raise ProblemError(f"sizes must be integers >= 2, got {self.sizes}")
        if not (self.time_limit_s > 0):
            raise ProblemError(f"time_limit_s must be positive, got {self.time_limit_s}")
        if self.threads < 1:
            raise ProblemError(f"threads must be at least 1, got {self.threads}")

    def methods(self) -> list[Method]:
        """Every compared method, references first."""
        compared = methods(self.formulations, self.backends, self.kernel, self.ls_svr)
        references = [REFERENCES["epsilon_svr"]] + ([REFERENCES["ls_svr"]] if self.ls_svr else [])
        return references + compared

    def n_runs(self) -> int:
        """Number of rows the benchmark will produce."""
        return len(self.datasets) * len(self.sizes) * len(self.methods())


def import_backends(methods_: Sequence[Method]) -> None:
    """Import every package the methods use, once, so forked children do not pay the import."""
    import importlib

    import qpsolvers  # noqa: F401
    import sklearn.svm  # noqa: F401

    for backend in {method.backend for method in methods_} & set(BACKENDS):
        importlib.import_module(BACKENDS[backend].package)


def run_benchmark(config: BenchConfig, on_run: Callable[[str], None] | None = None) -> pd.DataFrame:
    """Run every method on every dataset and size (ascending n) and return the tidy table of rows.

    ``on_run(description)`` is called after each run (for a progress bar). A method that hit
    the time limit on a dataset is marked ``"skipped"`` at every larger n of that dataset.
    """
    profile = PROFILES[config.profile]
    all_methods = config.methods()
    import_backends(all_methods)
    rows = []
    for dataset in config.datasets:
        timed_out: set[Method] = set()
        for n in sorted(config.sizes):
            case = make_case(dataset, n, config.d, kernel=config.kernel, C=config.C,
                             epsilon=config.epsilon, gamma=config.gamma, seed=config.seed)
            references: dict[str, RunOutcome] = {}
            for method in all_methods:
                if method in timed_out:
                    outcome = RunOutcome(status="skipped", total_time_s=config.time_limit_s,
                                         error="hit the time limit at a smaller n")
                else:
                    outcome = run_isolated(case, method, profile, config.time_limit_s,
                                           config.threads)
                if outcome.status == "time_limit":
                    timed_out.add(method)
                if method == REFERENCES[method.problem]:
                    references[method.problem] = outcome  # its own row compares with nothing
                    rows.append(evaluate(outcome, method, case, None, profile))
                else:
                    rows.append(evaluate(outcome, method, case, references.get(method.problem),
                                         profile))
                if on_run is not None:
                    on_run(f"{dataset} n={n} {method.label}: {outcome.status}")
    return pd.DataFrame(rows, columns=list(ROW_COLUMNS))
