"""ε-SVR with the RBF kernel: svrqp's exact paths and stock QP backends against libsvm (scikit-learn SVR).

Target (issue 6): svrqp's fastest exact path at most 1.0× libsvm's time at n = 4000 and 8000
(stretch 0.5×), same data for both, ratios from one run, objective within 1e-8 relative and
predictions within 1e-4·std(y) of ``SVR(tol=1e-8)``. Results go to
``benchmarks/results/epsilon_svr_vs_libsvm.{csv,md}`` and ``..._time_vs_n.png``.

The dataset panel (``--panel``, module :mod:`epsilon_svr_panel` next to this script) times the
default ``EpsilonSVR()`` (``solver="auto"``) and ``solver="dual_ipm"`` against libsvm on
friedman1, a sinc-like set, the smooth thermal generator with noisy sensors, ``miao2013`` and
``yang_turning``, at small and large C; results go to ``..._panel.{csv,md}``.

Usage::

    .venv/bin/python benchmarks/epsilon_svr_vs_libsvm.py --sizes 500,1000,2000 --force
    .venv/bin/python benchmarks/epsilon_svr_vs_libsvm.py --sizes 4000,8000 --stem epsilon_svr_vs_libsvm_large
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/epsilon_svr_vs_libsvm.py --panel --force
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rich.progress import Progress

from svrqp.bench.report import write_outputs
from svrqp.bench.run import BenchConfig, run_benchmark

RESULTS = Path(__file__).resolve().parent / "results"

NOTES = """## What is compared

- `libsvm/smo`: scikit-learn's `SVR(tol=1e-8)` (libsvm's SMO, kernel cache 1000 MB), the reference.
- `<backend>/split`: the β-split dual QP of `svrqp.formulations.epsilon_svr` handed to a stock
  backend through `svrqp.solvers` (dense Gram matrix inside a sparse P).
- `dual_ipm/dense`: `svrqp.solvers.dual_ipm.exact.solve_exact` — an interior point whose Newton systems are the
  reduced n×n matrix K + D⁻¹ factorised by dense LAPACK Cholesky, followed by an active-set
  crossover to the exact optimum (every KKT condition to rounding).
- `dual_ipm/auto`: `svrqp.solvers.dual_ipm.exact.solve_exact_from_data` — tries a pivoted-Cholesky factor of
  rank ≤ n/8 first (Woodbury solves in O(nr²), exact kernel columns of the support vectors only
  in the crossover) and falls back to the dense path when the kernel is not low-rank.

Datasets: `friedman1` (Friedman #1, noise 1, 10 features: most points are free support vectors,
the slow case for SMO) and `thermal` (S0-like warm-up curves of 10 temperatures: smooth, low
numerical rank, few free support vectors — the fast case for SMO). Both standardised;
C = 10, ε = 0.1, γ = 1/(d·Var X) = 0.1.
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="500,1000,2000", help="comma-separated n")
    parser.add_argument("--datasets", default="friedman1,thermal", help="comma-separated generated datasets")
    parser.add_argument("--backends", default="clarabel,osqp,piqp,highs",
                        help="stock QP backends run on the split dual")
    parser.add_argument("--time-limit", type=float, default=300.0, help="seconds per run")
    parser.add_argument("--stem", default="epsilon_svr_vs_libsvm", help="output file name stem")
    parser.add_argument("--force", action="store_true", help="overwrite existing results")
    parser.add_argument("--panel", action="store_true", help="run the dataset panel (default solver vs libsvm)")
    parser.add_argument("--panel-sizes", default="1000,2000,4000", help="comma-separated n of the panel")
    args = parser.parse_args()
    if args.panel:
        from epsilon_svr_panel import run_panel

        print(run_panel(tuple(int(n) for n in args.panel_sizes.split(",")), RESULTS, force=args.force))
        return
    config = BenchConfig(
        datasets=tuple(args.datasets.split(",")), sizes=tuple(int(n) for n in args.sizes.split(",")), d=10,
        kernel="rbf", C=10.0, epsilon=0.1, gamma="scale", formulations=("split", "dense", "auto"),
        backends=(*args.backends.split(","), "dual_ipm"), time_limit_s=args.time_limit, threads=1,
    )
    with Progress() as progress:
        task = progress.add_task("epsilon-SVR vs libsvm", total=config.n_runs())
        rows = run_benchmark(config, on_run=lambda text: progress.update(task, advance=1, description=text))
    paths = write_outputs(rows, config, RESULTS, force=args.force, stem=args.stem,
                          title="epsilon-SVR (RBF): svrqp against libsvm", extra_sections=[NOTES])
    print("\n".join(str(path) for path in paths.values()))


if __name__ == "__main__":
    main()
