"""ε-SVR (RBF) at n = 100 000 with a pivoted-Cholesky factor: time, memory, and the accuracy it costs.

Target (issue 6): n = 10⁵ in at most 2 minutes with memory O(n·r), the accuracy loss against an
exact fit on a subsample reported. The factored dual (:mod:`svrqp.formulations.low_rank`) is
solved by :func:`svrqp.solvers.dual_ipm.interior_point` on :math:`K \\approx LL^\\top` (Woodbury, O(nr²) per
iteration); no n×n matrix is ever formed. The loss is measured three ways:

1. on a subsample of m points, the low-rank fit (same factor settings) against the exact fit of
   scikit-learn's ``SVR(tol=1e-8)`` (libsvm, independent of svrqp): relative dual-objective gap
   (exact kernel), largest prediction difference / std(y), and the a-priori bound
   :func:`svrqp.formulations.low_rank.objective_error_bound`;
2. test RMSE on held-out points: the n = 10⁵ low-rank model against the exact model of the subsample,
   the low-rank model predicting with the exact kernel over its support vectors and with its pivot
   expansion (:func:`svrqp.formulations.low_rank.pivot_coefficients`, the model that was optimised);
3. the relative trace error :math:`\\operatorname{tr}(K - LL^\\top)/\\operatorname{tr}K` of each factor.

Memory: the process's peak RSS (``getrusage``) right after the n = 10⁵ fit (nothing larger is
allocated before it), next to the size of L. Writes ``benchmarks/results/low_rank_scale_<dataset>.md``
and ``.csv``.
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.svm import SVR
from threadpoolctl import threadpool_limits

from svrqp.solvers import dual_ipm
from svrqp.bench.cases import GENERATORS, resolve_gamma
from svrqp.bench.report import machine_info, machine_sentence, markdown_table, package_versions
from svrqp.formulations.epsilon_svr import dual_objective
from svrqp.formulations.low_rank import objective_error_bound, pivot_coefficients
from svrqp.linalg.pivoted_cholesky import pivoted_cholesky
from svrqp.linalg.kernel_columns import KernelColumns
from svrqp.kernels import gram

RESULTS = Path(__file__).resolve().parent / "results"
C, EPSILON = 10.0, 0.1


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far (Linux reports kilobytes)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def low_rank_fit(X: np.ndarray, y: np.ndarray, gamma: float, factor_tol: float, max_rank: int):
    """Factor, then the interior point on L L^T: (fit, factor, factor seconds, IPM seconds)."""
    start = time.perf_counter()
    factor = pivoted_cholesky(KernelColumns(X, gamma=gamma), max_rank=max_rank, tol=factor_tol, cache=False)
    factored = time.perf_counter()
    fit = dual_ipm.interior_point(dual_ipm.FactoredKernel(factor.L), y, C, EPSILON)
    return fit, factor, factored - start, time.perf_counter() - factored


def predict(X_train: np.ndarray, beta: np.ndarray, b: float, X_new: np.ndarray, gamma: float,
            chunk: int = 100) -> np.ndarray:
    """Decision function with the exact kernel, over the support vectors only, in row blocks."""
    support = np.flatnonzero(beta)
    return np.concatenate([gram(X_new[i:i + chunk], X_train[support], gamma=gamma) @ beta[support] + b
                           for i in range(0, X_new.shape[0], chunk)])


def predict_by_pivots(X_train: np.ndarray, factor, beta: np.ndarray, b: float, X_new: np.ndarray,
                      gamma: float) -> np.ndarray:
    """The factored model that was optimised: its expansion over the pivots (r kernel values a point)."""
    return gram(X_new, X_train[factor.pivots], gamma=gamma) @ pivot_coefficients(factor, beta) + b


def rmse(prediction: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean((prediction - truth) ** 2)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100_000)
    parser.add_argument("--subsample", type=int, default=5000)
    parser.add_argument("--test", type=int, default=10_000)
    parser.add_argument("--dataset", default="thermal", choices=sorted(GENERATORS))
    parser.add_argument("--factor-tol", type=float, default=1e-6)
    parser.add_argument("--max-rank", type=int, default=500)
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args()
    output = RESULTS / f"low_rank_scale_{args.dataset}.md"
    if output.exists() and not args.force:
        raise SystemExit(f"{output} exists; pass --force to overwrite")
    X_all, y_all = GENERATORS[args.dataset](args.n + args.test, 10, 0)
    X, y, X_test, y_test = X_all[:args.n], y_all[:args.n], X_all[args.n:], y_all[args.n:]
    gamma = resolve_gamma("scale", X)
    settings = (gamma, args.factor_tol, args.max_rank)
    rows = []
    with threadpool_limits(1):
        rss_before = peak_rss_mb()
        fit, factor, factor_s, ipm_s = low_rank_fit(X, y, *settings)
        rss_after = peak_rss_mb()
        rows.append({"fit": f"low rank, n = {args.n}", "seconds": factor_s + ipm_s, "factor_s": factor_s,
                     "ipm_s": ipm_s, "rank": factor.rank, "relative_trace_error": factor.relative_trace_error,
                     "objective_error_bound": objective_error_bound(factor, args.n, C),
                     "ipm_iterations": fit.iterations, "converged": fit.converged,
                     "L_MB": factor.L.nbytes / 2**20, "peak_RSS_MB": rss_after,
                     "peak_RSS_growth_MB": rss_after - rss_before,
                     "test_RMSE": rmse(predict(X, fit.beta, fit.intercept, X_test, gamma), y_test),
                     "test_RMSE_pivots": rmse(predict_by_pivots(X, factor, fit.beta, fit.intercept, X_test, gamma),
                                              y_test)})

        sub = slice(0, args.subsample)
        X_sub, y_sub = X[sub], y[sub]
        small_fit, small_factor, small_factor_s, small_ipm_s = low_rank_fit(X_sub, y_sub, *settings)
        start = time.perf_counter()
        exact = SVR(kernel="rbf", gamma=gamma, C=C, epsilon=EPSILON, tol=1e-8, cache_size=2000).fit(X_sub, y_sub)
        exact_s = time.perf_counter() - start
        beta_exact = np.zeros(args.subsample)
        beta_exact[exact.support_] = exact.dual_coef_[0]
        K_sub = gram(X_sub, gamma=gamma)
        objective_exact = dual_objective(K_sub, y_sub, beta_exact, EPSILON)
        objective_low = dual_objective(K_sub, y_sub, small_fit.beta, EPSILON)
        difference = (K_sub @ small_fit.beta + small_fit.intercept) - exact.predict(X_sub)
        difference_pivots = (predict_by_pivots(X_sub, small_factor, small_fit.beta, small_fit.intercept, X_sub, gamma)
                             - exact.predict(X_sub))
        rows.append({"fit": f"exact SVR(tol=1e-8), subsample m = {args.subsample}", "seconds": exact_s,
                     "rank": args.subsample, "relative_trace_error": 0.0,
                     "test_RMSE": rmse(exact.predict(X_test), y_test)})
        rows.append({"fit": f"low rank, subsample m = {args.subsample}", "seconds": small_factor_s + small_ipm_s,
                     "factor_s": small_factor_s, "ipm_s": small_ipm_s, "rank": small_factor.rank,
                     "relative_trace_error": small_factor.relative_trace_error,
                     "objective_error_bound": objective_error_bound(small_factor, args.subsample, C),
                     "ipm_iterations": small_fit.iterations, "converged": small_fit.converged,
                     "objective_gap_vs_exact": objective_low - objective_exact,
                     "objective_gap_rel_vs_exact": (objective_low - objective_exact) / abs(objective_exact),
                     "prediction_diff_rel_vs_exact": float(np.max(np.abs(difference)) / np.std(y_sub)),
                     "prediction_diff_rel_vs_exact_pivots": float(np.max(np.abs(difference_pivots)) / np.std(y_sub)),
                     "test_RMSE": rmse(predict(X_sub, small_fit.beta, small_fit.intercept, X_test, gamma), y_test),
                     "test_RMSE_pivots": rmse(predict_by_pivots(X_sub, small_factor, small_fit.beta, small_fit.intercept,
                                                                X_test, gamma), y_test)})
        machine = machine_info()
    frame = pd.DataFrame(rows)
    frame.to_csv(output.with_suffix(".csv"), index=False)
    large, exact_row, small = rows
    summary = (
        f"RBF, gamma = {gamma:.3g} (scale), C = {C:g}, epsilon = {EPSILON:g}, d = 10; greedy pivoted Cholesky "
        f"to relative trace error {args.factor_tol:g} or rank "
        f"{args.max_rank}; one BLAS thread. Target: <= 120 s, memory O(n r). **Measured: {large['seconds']:.1f} s "
        f"at rank {large['rank']}** (factor {large['factor_s']:.1f} s, interior point {large['ipm_s']:.1f} s); "
        f"L is {large['L_MB']:.0f} MB, the process's peak RSS {large['peak_RSS_MB']:.0f} MB "
        f"(an n x n matrix would be {8 * args.n**2 / 2**30:.0f} GB). Accuracy on the m = {args.subsample} "
        f"subsample: the low-rank optimum's exact-kernel dual objective is {small['objective_gap_rel_vs_exact']:.2e} "
        f"(relative) above libsvm's; predictions differ by up to {small['prediction_diff_rel_vs_exact']:.3g} std(y) "
        f"with the exact kernel and {small['prediction_diff_rel_vs_exact_pivots']:.3g} std(y) with the pivot "
        f"expansion. Held-out RMSE ({args.test} points, standardised y): n = {args.n} low rank "
        f"{large['test_RMSE']:.4f} (exact kernel) / {large['test_RMSE_pivots']:.4f} (pivot expansion), "
        f"exact m = {args.subsample} {exact_row['test_RMSE']:.4f}.")
    limitations = (
        "## Limitations\n\n"
        "The n = 10⁵ fit is not certified against the exact problem (that would need the n×n kernel): "
        "its accuracy is judged on the subsample, where the same factor settings are compared with an exact "
        "fit, and by held-out RMSE. With a coarse factor the exact-kernel decision function is not the model "
        "that was optimised and can be far off; the pivot expansion is. The a-priori `objective_error_bound` (n C² tr(K - LL^T) / 2) is far "
        "looser than the measured gap. The interior point stops at its own tolerance (1e-8 relative "
        "residuals) on the factored problem, without a crossover. Peak RSS is the whole process's (Python, "
        "the data and the n = 10⁵ factor with the interior point's n×r work arrays; it is read before any "
        "subsample work). One run on a machine shared with other work, serialised with other benchmarks "
        "by a lock but not isolated from other load.")
    output.write_text("\n\n".join([
        f"# Low-rank epsilon-SVR at n = {args.n} ({args.dataset})",
        summary,
        markdown_table(frame),
        machine_sentence(machine, package_versions()),
        limitations,
    ]) + "\n")
    print(output.read_text())


if __name__ == "__main__":
    main()
