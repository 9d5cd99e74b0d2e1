"""LS-SVR at n = 8000: ``LSSVR.fit`` against its floor, one Gram build plus one Cholesky of n×n.

Target (issue 6): the fit takes at most 1.1× (Gram build + one Cholesky factorisation of
:math:`\\Omega + I/C`), measured in the same run with the same BLAS threads. Writes
``benchmarks/results/ls_svr_cholesky.md``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.linalg
from threadpoolctl import threadpool_limits

from svrqp import LSSVR
from svrqp.bench import make_case
from svrqp.bench_report import machine_info, markdown_table, package_versions
from svrqp.kernels import gram

RESULTS = Path(__file__).resolve().parent / "results"


def floor_time(X: np.ndarray, gamma: float, C: float) -> float:
    """Seconds for the unavoidable work: the Gram matrix and one Cholesky of Omega + I/C."""
    start = time.perf_counter()
    K = gram(X, gamma=gamma)
    K.flat[:: K.shape[0] + 1] += 1.0 / C
    scipy.linalg.cho_factor(K, lower=True, overwrite_a=True, check_finite=False)
    return time.perf_counter() - start


def fit_time(X: np.ndarray, y: np.ndarray, gamma: float, C: float) -> float:
    start = time.perf_counter()
    LSSVR(C=C, gamma=gamma).fit(X, y)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=8000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args()
    output = RESULTS / "ls_svr_cholesky.md"
    if output.exists() and not args.force:
        raise SystemExit(f"{output} exists; pass --force to overwrite")
    case = make_case("friedman1", args.n, 10, C=10.0)
    floors, fits = [], []
    with threadpool_limits(args.threads):
        for _ in range(args.repeats):  # interleaved, so both see the same machine load
            floors.append(floor_time(case.X, case.gamma, case.C))
            fits.append(fit_time(case.X, case.y, case.gamma, case.C))
    floor, fit = statistics.median(floors), statistics.median(fits)
    table = markdown_table(pd.DataFrame([
        {"n": args.n, "threads": args.threads, "floor_s (median)": floor, "LSSVR.fit_s (median)": fit,
         "ratio": fit / floor, "floor_runs_s": " ".join(f"{t:.2f}" for t in floors),
         "fit_runs_s": " ".join(f"{t:.2f}" for t in fits)}]))
    machine = machine_info()
    versions = package_versions()
    output.write_text("\n\n".join([
        "# LS-SVR: fit time against Gram build + one Cholesky",
        f"Dataset friedman1 (d = 10, standardised), C = {case.C:g}, gamma = {case.gamma:.3g}; target ratio <= 1.1.",
        table,
        f"Machine: {machine['cpu']}, {machine['cores_usable']} usable cores, OPENBLAS_CORETYPE = "
        f"{machine['OPENBLAS_CORETYPE']}, BLAS kernels: "
        + ", ".join(f"{pool['library']} ({pool['architecture']})" for pool in machine["thread_pools"]
                    if pool["user_api"] == "blas")
        + ". Versions: " + ", ".join(f"{name} {value}" for name, value in versions.items()) + ".",
        "## Limitations\n\nThe fit includes input validation, the KKT certificate of the solution (one "
        "n×n product) and the Schur-complement solves; the floor is the Gram build and the factorisation "
        "only. Medians of interleaved repeats on a machine shared with other work.",
    ]) + "\n")
    print(output.read_text())


if __name__ == "__main__":
    main()
