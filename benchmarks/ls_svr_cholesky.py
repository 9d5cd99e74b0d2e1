"""LS-SVR at n = 8000: ``LSSVR.fit`` against its floor, one Gram build plus one Cholesky of n×n.

Target (issue 6): the fit takes at most 1.1× (Gram build + one Cholesky factorisation of
:math:`\\Omega + I/C`). The reference floor is what a user of the standard libraries writes:
``sklearn.metrics.pairwise.rbf_kernel``, :math:`I/C` added in place, ``scipy.linalg.cho_factor``
(``overwrite_a=True``); a tighter floor uses svrqp's in-place Gram and factors its Fortran view
(no copy at all). The formulation core is what ``LSSVR.fit`` does without its validation and stored
KKT matrix. ``KernelRidge`` (no bias) is timed for information. All in the same run, with
the same BLAS threads, repeats interleaved. Peak memory of each is measured separately with
``tracemalloc`` (numpy's allocations are traced; the timing runs are not slowed by it).
Writes ``benchmarks/results/ls_svr_cholesky.md`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import statistics
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.linalg
from sklearn.kernel_ridge import KernelRidge
from sklearn.metrics.pairwise import rbf_kernel
from threadpoolctl import threadpool_limits

from svrqp import LSSVR
from svrqp.bench.cases import make_case
from svrqp.bench.report import machine_info, machine_sentence, markdown_table, package_versions
from svrqp.formulations.ls_svr import solve_cholesky_schur
from svrqp.kernels import gram

RESULTS = Path(__file__).resolve().parent / "results"


def reference_floor(X: np.ndarray, y: np.ndarray, gamma: float, C: float) -> None:
    """scikit-learn's RBF Gram matrix, I/C added in place, scipy's Cholesky (it copies a C-ordered K)."""
    K = rbf_kernel(X, gamma=gamma)
    K.flat[:: K.shape[0] + 1] += 1.0 / C
    scipy.linalg.cho_factor(K, lower=True, overwrite_a=True, check_finite=False)


def tight_floor(X: np.ndarray, y: np.ndarray, gamma: float, C: float) -> None:
    """svrqp's in-place Gram matrix and LAPACK on its Fortran view: no n×n array besides K."""
    K = gram(X, gamma=gamma)
    K.flat[:: K.shape[0] + 1] += 1.0 / C
    scipy.linalg.cho_factor(K.T, lower=False, overwrite_a=True, check_finite=False)


def lssvr_fit(X: np.ndarray, y: np.ndarray, gamma: float, C: float) -> None:
    """svrqp's estimator: validation, Gram, the stored KKT system, Cholesky + Schur, certificate."""
    LSSVR(C=C, gamma=gamma).fit(X, y)


def formulation_core(X: np.ndarray, y: np.ndarray, gamma: float, C: float) -> None:
    """svrqp's Gram and :func:`svrqp.formulations.ls_svr.solve_cholesky_schur` factoring K itself."""
    solve_cholesky_schur(gram(X, gamma=gamma), y, C, overwrite_K=True)


def kernel_ridge_fit(X: np.ndarray, y: np.ndarray, gamma: float, C: float) -> None:
    """scikit-learn's KernelRidge(alpha = 1/C): the same system without the bias, for information."""
    KernelRidge(alpha=1.0 / C, kernel="rbf", gamma=gamma).fit(X, y)


METHODS: dict[str, Callable[[np.ndarray, np.ndarray, float, float], None]] = {
    "reference floor (rbf_kernel + cho_factor)": reference_floor,
    "tight floor (svrqp gram + in-place cho_factor)": tight_floor,
    "LSSVR.fit": lssvr_fit,
    "formulation core (gram + solve_cholesky_schur, overwrite_K)": formulation_core,
    "KernelRidge.fit (no bias)": kernel_ridge_fit,
}


def seconds(method: Callable, *args) -> float:
    start = time.perf_counter()
    method(*args)
    return time.perf_counter() - start


def peak_traced_bytes(method: Callable, *args) -> int:
    """Largest memory held at once during ``method`` by Python and numpy allocations."""
    tracemalloc.start()
    try:
        method(*args)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


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
    arguments = (case.X, case.y, case.gamma, case.C)
    times: dict[str, list[float]] = {name: [] for name in METHODS}
    with threadpool_limits(args.threads):
        for _ in range(args.repeats):  # interleaved, so every method sees the same machine load
            for name, method in METHODS.items():
                times[name].append(seconds(method, *arguments))
        peaks = {name: peak_traced_bytes(method, *arguments) for name, method in METHODS.items()}
        machine = machine_info()  # inside the limit, so the thread counts recorded are the ones used
    reference_runs = times["reference floor (rbf_kernel + cho_factor)"]
    tight_runs = times["tight floor (svrqp gram + in-place cho_factor)"]
    matrix_bytes = 8 * args.n**2
    frame = pd.DataFrame([
        {"method": name, "n": args.n, "threads": args.threads, "median_s": statistics.median(runs),
         "min_s": min(runs),
         "ratio_to_reference_floor": statistics.median(runs) / statistics.median(reference_runs),
         "ratio_to_reference_floor_min": min(runs) / min(reference_runs),
         "ratio_to_tight_floor": statistics.median(runs) / statistics.median(tight_runs),
         "peak_traced_MB": peaks[name] / 2**20, "peak_in_nxn_matrices": peaks[name] / matrix_bytes,
         "runs_s": " ".join(f"{t:.2f}" for t in runs)}
        for name, runs in times.items()])
    frame.to_csv(output.with_suffix(".csv"), index=False)
    fit = frame.set_index("method").loc["LSSVR.fit"]
    output.write_text("\n\n".join([
        "# LS-SVR: fit time against Gram build + one Cholesky",
        (f"Dataset friedman1 (n = {args.n}, d = 10, standardised), RBF, C = {case.C:g}, gamma = {case.gamma:.3g} "
        f"(scale). Target: `LSSVR.fit` <= 1.1 x the reference floor. Measured: **{fit['ratio_to_reference_floor']:.2f} x** "
        f"(medians of {args.repeats} interleaved repeats; {fit['ratio_to_reference_floor_min']:.2f} x by the fastest "
        f"repeat of each), {fit['ratio_to_tight_floor']:.2f} x the tight floor; peak memory "
        f"{fit['peak_in_nxn_matrices']:.2f} n x n matrices (an n x n float64 matrix is {matrix_bytes / 2**20:.0f} MB)."),
        markdown_table(frame),
        machine_sentence(machine, package_versions()),
        ("## Limitations\n\n"
        "The fit includes input validation (the KKT matrix `problem_` is no longer formed: it is rebuilt on demand), the "
        "Cholesky factorisation in place of the fit's own Gram matrix, the Schur-complement solves and the certificate (one symmetric "
        "matrix-vector product); the floors are the Gram build and the factorisation only. The reference "
        "floor's `cho_factor` copies the C-ordered K to Fortran order inside scipy (what `overwrite_a=True` "
        "gives a C-ordered array); the tight floor avoids that copy. Peak memory is tracemalloc's count of "
        "Python and numpy allocations (LAPACK and OpenBLAS work buffers are not traced), from one separate "
        "run of each method. Timings are from one process on a machine shared with other work, serialised "
        "with other benchmarks by a lock but not isolated from other load."),
    ]) + "\n")
    print(output.read_text())


if __name__ == "__main__":
    main()
