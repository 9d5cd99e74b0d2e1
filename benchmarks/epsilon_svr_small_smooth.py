"""Issue 38: the default ``EpsilonSVR()`` against libsvm at every size, on small and smooth data.

Two generators, those of ``epsilon_svr_panel.py`` (X and y standardised, RBF kernel, C = 10,
ε = 0.1): ``sinc`` (5 inputs, γ = 0.5) and ``thermal`` (10 warm-up sensors with reading noise,
γ = 0.1), at n = 50, 200, 1000, 4000 and 8000. Per cell, libsvm (``SVR(tol=1e-8,
cache_size=2000)``) and the default ``EpsilonSVR()`` are timed *interleaved* (one libsvm fit, one
svrqp fit, repeated), so that both see the same load of this shared machine; the table gives the
median of each and their ratio, and the ratio of the fastest fits (the least disturbed ones: a
fit of a millisecond is often preempted for 5 ms on this machine).

Exactness is judged independently of svrqp's code: ``dev_exact_std`` is the largest difference of
the predictions at the training points from those of the dual QP solved by Clarabel through cvxpy
(tolerances 1e-10; n ≤ ``EXACT_MAX_N``), over std(y); ``kkt_std`` is the largest violation of the
ε-SVR optimality conditions (S0 eq. 6) by svrqp's (β, b), computed in plain numpy with
scikit-learn's ``rbf_kernel``, over std(y) (the answer is optimal for targets within that of y);
``objective_rel`` is svrqp's dual objective minus libsvm's at tol = 1e-12, relative (negative:
lower, i.e. better); ``exact_kkt_std`` is the reference's own violation, as ``kkt_std``. An
interior point stops inside the box, a little off its active set (Clarabel's violation reached
7e-3·std(y) on the sinc at n = 1000): the reference is Clarabel's answer polished on its active set
in plain numpy (``polished``: the free-set system solved, contradicted states changed until none
is), where that lowers its violation.
``dev_libsvm_std`` compares with libsvm at tol = 1e-12 and
``libsvm8_dev_std`` libsvm at 1e-8 with it; ``libsvm_kkt_std`` is libsvm's (tol 1e-12) own
violation, as ``kkt_std``: on smooth data libsvm stops with KKT violations of
1e-6·std(y) whatever its tol (1e-8, 1e-12 and 1e-15 tried), so it is no exact reference there.
``certificate`` is the largest relative residual svrqp's answer carries (stated QP: primal, dual,
gap; the model's box, balance and KKT conditions): at most ``check_tol`` = 1e-6, or the fit
raises.

``--grid`` adds tuning's 5×5 grid (C in 0.1 … 1000, γ in 0.01 … 1, ε = 0.1, 5-fold ``KFold``)
on the thermal generator at n = 200: ``grid_search`` with its defaults against
``GridSearchCV(SVR(tol=1e-8))``, CPU time of this single-threaded process (less disturbed by
the machine's other work than wall time), the largest relative difference of a candidate's CV
mean squared error, and the best candidate of each.

``--profile`` adds, per cell, where svrqp's time goes (cProfile, cumulative time of each stage
as a share of the fit): validation, the loose SMO (with screening's pilot runs), the crossover,
the certificate on the stated QP and the rest (the estimator's bookkeeping, the solver's
dispatch).

Usage::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/epsilon_svr_small_smooth.py --force
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/epsilon_svr_small_smooth.py \\
        --sizes 50,200 --out /tmp/smoke.md          # a smoke run
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time
from pathlib import Path

import numpy as np
import pandas as pd
from epsilon_svr_panel import sinc, thermal_noisy  # the panel's generators, beside this script
from sklearn.metrics.pairwise import rbf_kernel
from sklearn.svm import SVR

from svrqp import EpsilonSVR
from svrqp.bench.report import machine_info, machine_sentence, markdown_table, package_versions

RESULTS = Path(__file__).resolve().parent / "results"
C, EPSILON = 10.0, 0.1
GENERATORS = {"sinc": (sinc, 0.5), "thermal": (thermal_noisy, 0.1)}
SIZES = (50, 200, 1000, 4000, 8000)
#: Interleaved pairs of fits per size (n above the last key: one pair).
REPEATS = {50: 41, 200: 21, 1000: 5, 4000: 1}
#: Cells whose first libsvm fit takes under SHORT_S seconds get at least SHORT_PAIRS pairs.
SHORT_S, SHORT_PAIRS = 1.0, 5
#: Largest n solved by Clarabel as the independent exact reference (a dense n×n factor).
EXACT_MAX_N = 1000
#: Stages of the profile: a stage's time is the cumulative time of the functions named.
STAGES = {
    "validation": ("_validated_training_data",),
    "loose SMO": ("decomposition_fit", "screened_fit", "_pilot"),  # with screening's pilots
    "crossover": ("crossover",),
    "certificate": ("stated_dual", "of_stated", "require_certificates", "kernel_scale"),
}


def repeats(n: int) -> int:
    """Interleaved pairs of fits at size ``n``."""
    return next((count for size, count in sorted(REPEATS.items()) if n <= size), 1)


def run_cell(kind: str, n: int, profile: bool) -> dict:
    """One generator at one size: interleaved timings, exactness, certificate (module docstring)."""
    generate, gamma = GENERATORS[kind]
    X, y = generate(n)
    libsvm = lambda: SVR(C=C, epsilon=EPSILON, gamma=gamma, tol=1e-8, cache_size=2000).fit(X, y)  # noqa: E731
    ours = lambda: EpsilonSVR(C=C, epsilon=EPSILON, gamma=gamma).fit(X, y)  # noqa: E731
    times: dict[str, list[float]] = {"libsvm": [], "svrqp": []}
    pairs = repeats(n)
    while len(times["svrqp"]) < pairs:
        for name, fit in (("libsvm", libsvm), ("svrqp", ours)):
            start = time.perf_counter()
            model = fit()
            times[name].append(time.perf_counter() - start)
            if name == "libsvm":
                reference_8 = model
        if times["libsvm"][0] < SHORT_S:  # a short cell: more pairs, as the panel does
            pairs = max(pairs, SHORT_PAIRS)
    tight = SVR(C=C, epsilon=EPSILON, gamma=gamma, tol=1e-12, cache_size=2000).fit(X, y)
    spread = float(np.std(y))
    beta, b = full_coefficients(model, n), float(model.intercept_[0])
    beta_tight = full_coefficients(tight, n)
    K_beta, K_beta_tight = kernel_times(X, gamma, beta), kernel_times(X, gamma, beta_tight)
    objective = dual_objective(y, beta, K_beta)
    residuals = model.solution_.residuals
    row = {
        "data": kind, "n": n, "pairs": pairs, "n_SV": int(model.support_.size),
        "libsvm_s": float(np.median(times["libsvm"])), "svrqp_s": float(np.median(times["svrqp"])),
        "libsvm_min_s": min(times["libsvm"]), "svrqp_min_s": min(times["svrqp"]),
        "path": model.solver_,
        "dev_exact_std": np.nan, "exact_kkt_std": np.nan,
        "kkt_std": kkt_violation(y, beta, K_beta + b) / spread,
        "objective_rel": (objective - dual_objective(y, beta_tight, K_beta_tight))
        / abs(objective),
        "dev_libsvm_std": float(np.max(np.abs(model.predict(X) - tight.predict(X)))) / spread,
        "libsvm8_dev_std": float(np.max(np.abs(reference_8.predict(X) - tight.predict(X))))
        / spread,
        "libsvm_kkt_std": kkt_violation(y, beta_tight, K_beta_tight + float(tight.intercept_[0]))
        / spread,
        "certificate": max(residuals[key] for key in ("primal_rel", "dual_rel", "gap_rel",
                                                       "box_rel", "balance_rel", "kkt_rel")),
    }
    if n <= EXACT_MAX_N:
        fitted, violation = exact_predictions(X, y, gamma)
        row["dev_exact_std"] = float(np.max(np.abs(K_beta + b - fitted))) / spread
        row["exact_kkt_std"] = violation / spread
    row["ratio"] = row["svrqp_s"] / row["libsvm_s"]
    row["ratio_min"] = row["svrqp_min_s"] / row["libsvm_min_s"]
    if profile:
        row.update(stage_shares(ours, min(pairs, 20)))
    return row


def full_coefficients(model, n: int) -> np.ndarray:
    """β of every training point (0 off the support) of a fitted SVR or EpsilonSVR."""
    beta = np.zeros(n)
    beta[model.support_] = model.dual_coef_[0]
    return beta


def kernel_times(X: np.ndarray, gamma: float, beta: np.ndarray) -> np.ndarray:
    """:math:`K\\beta` with scikit-learn's ``rbf_kernel``, over the support, in row blocks."""
    support = np.flatnonzero(beta)
    return np.concatenate([rbf_kernel(X[start:start + 1000], X[support], gamma=gamma)
                           @ beta[support] for start in range(0, X.shape[0], 1000)])


def dual_objective(y: np.ndarray, beta: np.ndarray, K_beta: np.ndarray) -> float:
    """The minimised ε-SVR dual: :math:`\\tfrac12\\beta^\\top K\\beta - y^\\top\\beta
    + \\varepsilon\\lVert\\beta\\rVert_1`."""
    return float(0.5 * beta @ K_beta - y @ beta + EPSILON * np.abs(beta).sum())


def kkt_violation(y: np.ndarray, beta: np.ndarray, fitted: np.ndarray,
                  tol: float = 1e-12) -> float:
    """Largest violation, in units of y, of the ε-SVR optimality conditions (S0 eq. 6):
    :math:`|r_i| \\le \\varepsilon` where :math:`\\beta_i = 0`, :math:`r_i = \\varepsilon\\,
    \\mathrm{sign}\\,\\beta_i` where :math:`0 < |\\beta_i| < C`, :math:`r_i` beyond the tube on
    the side of :math:`\\beta_i` where :math:`|\\beta_i| = C`, :math:`|\\beta_i| \\le C` and
    :math:`\\sum\\beta_i = 0` (times max K = 1); :math:`r = y - f`. Coefficients within
    ``tol``·C of 0 or of ±C count as there."""
    r, sign = y - fitted, np.sign(beta)
    zero, bound = np.abs(beta) <= tol * C, np.abs(beta) >= C * (1.0 - tol)
    free = ~zero & ~bound
    return float(max(np.max(np.maximum(np.abs(r[zero]) - EPSILON, 0.0), initial=0.0),
                     np.max(np.abs(r[free] - EPSILON * sign[free]), initial=0.0),
                     np.max(np.maximum(EPSILON - sign[bound] * r[bound], 0.0), initial=0.0),
                     np.max(np.abs(beta) - C, initial=0.0), abs(float(beta.sum()))))


def exact_predictions(X: np.ndarray, y: np.ndarray, gamma: float) -> tuple[np.ndarray, float]:
    """Predictions at X of the dual QP solved by Clarabel through cvxpy (the module docstring),
    and their own :func:`kkt_violation` (an interior point's coefficients stay inside the box:
    within 1e-8·C of 0 or ±C they count as there)."""
    import cvxpy as cp

    K = rbf_kernel(X, gamma=gamma)
    values, vectors = np.linalg.eigh(K)
    L = vectors * np.sqrt(np.clip(values, 0.0, None))  # K = L Lᵀ
    alpha, alpha_star = cp.Variable(y.size), cp.Variable(y.size)
    beta = alpha_star - alpha
    balance = cp.sum(beta) == 0
    problem = cp.Problem(cp.Minimize(0.5 * cp.sum_squares(L.T @ beta) - y @ beta
                                     + EPSILON * cp.sum(alpha + alpha_star)),
                         [balance, alpha >= 0, alpha <= C, alpha_star >= 0, alpha_star <= C])
    problem.solve(solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10)
    # the bias is the multiplier of Σβ = 0 (S0 eq. 6; cvxpy's sign, checked: the difference from
    # svrqp's predictions has no constant part)
    fitted = K @ beta.value + float(balance.dual_value)
    clarabel = fitted, kkt_violation(y, beta.value, fitted, tol=1e-8)
    polish = polished(K, y, beta.value)
    return polish if polish is not None and polish[1] < clarabel[1] else clarabel


def polished(K: np.ndarray, y: np.ndarray, beta: np.ndarray,
             max_steps: int = 50) -> tuple[np.ndarray, float] | None:
    r"""An interior point's β made exact on its active set, in plain numpy (an OSQP-style polish,
    written here apart from svrqp): states read from β (within 1e-6·C of 0 or ±C), then the
    free-set system :math:`K_{FF}\beta_F + b = y_F - \varepsilon s_F - K_{FB}\beta_B`,
    :math:`\mathbf 1^\top\beta_F = -\mathbf 1^\top\beta_B` solved and every state its solution
    or residual contradicts changed, until none is (Hintermüller, Ito & Kunisch 2002). Returns the
    predictions and their :func:`kkt_violation`, or None when the states do not settle."""
    sign = np.where(np.abs(beta) <= 1e-6 * C, 0, np.sign(beta)).astype(int)
    bound = np.abs(beta) >= C * (1.0 - 1e-6)
    for _ in range(max_steps):
        free = np.flatnonzero((sign != 0) & ~bound)
        fixed = np.where(bound, sign * C, 0.0)
        rhs = y[free] - EPSILON * sign[free] - K[free] @ fixed
        system = np.block([[K[np.ix_(free, free)], np.ones((free.size, 1))],
                           [np.ones((1, free.size)), np.zeros((1, 1))]])
        solution = np.linalg.lstsq(system, np.append(rhs, -fixed.sum()), rcond=None)[0]
        candidate = fixed.copy()
        candidate[free] = solution[:-1]
        fitted = K @ candidate + solution[-1]
        r = y - fitted
        new_sign, new_bound = sign.copy(), bound.copy()
        crossed = np.zeros(y.size, dtype=bool)
        crossed[free] = candidate[free] * sign[free] <= 0.0  # left its sign: to zero
        new_sign[crossed] = 0
        over = np.zeros(y.size, dtype=bool)
        over[free] = np.abs(candidate[free]) > C  # left the box: to its bound
        new_bound |= over
        entering = (sign == 0) & (np.abs(r) > EPSILON)  # outside the tube at zero: freed
        new_sign[entering] = np.sign(r[entering]).astype(int)
        released = bound & (sign * r < EPSILON)  # at a bound inside the tube: freed
        new_bound &= ~released
        if np.array_equal(new_sign, sign) and np.array_equal(new_bound, bound):
            return fitted, kkt_violation(y, candidate, fitted)
        sign, bound = new_sign, new_bound
    return None


def stage_shares(fit, count: int) -> dict[str, float]:
    """Share of ``count`` profiled fits' time in each of :data:`STAGES`, and the rest."""
    profiler = cProfile.Profile()
    profiler.enable()
    for _ in range(count):
        fit()
    profiler.disable()
    stats = pstats.Stats(profiler).stats  # (file, line, name) -> (cc, nc, tt, ct, callers)
    total = max(ct for (path, _, name), (_, _, _, ct, _) in stats.items()
                if name == "fit" and path.endswith("kernel.py"))
    shares = {}
    for stage, names in STAGES.items():
        # outermost calls only: the time a stage function spends called from another function
        # of the same stage is not counted twice (the pilot calls decomposition_fit)
        seconds = sum(timing[3] for (_, _, name), (*_, callers) in stats.items() if name in names
                      for caller, timing in callers.items() if caller[2] not in names)
        shares[f"{stage} %"] = 100.0 * seconds / total
    shares["other %"] = 100.0 - sum(shares.values())
    return shares


def run_grid(n: int = 200) -> pd.DataFrame:
    """Tuning's 5×5 grid against GridSearchCV(SVR(tol=1e-8)) (module docstring), best of 2 runs."""
    from sklearn.model_selection import GridSearchCV, KFold

    from svrqp.tuning import Execution, grid_search

    X, y = thermal_noisy(n)
    C_grid, gamma_grid = [0.1, 1.0, 10.0, 100.0, 1000.0], [float(g) for g in np.logspace(-2, 0, 5)]
    folds, cpu = KFold(5), {"svrqp": [], "GridSearchCV": []}
    for _ in range(2):
        start = time.process_time()
        reference = GridSearchCV(SVR(epsilon=EPSILON, tol=1e-8), {"C": C_grid, "gamma": gamma_grid},
                                 cv=folds, scoring="neg_mean_squared_error", refit=False).fit(X, y)
        cpu["GridSearchCV"].append(time.process_time() - start)
        start = time.process_time()
        ours = grid_search(X, y, C=C_grid, gamma=gamma_grid, epsilon=[EPSILON],
                           execution=Execution(cv=folds, backend="sequential"))
        cpu["svrqp"].append(time.process_time() - start)
    theirs = pd.DataFrame(reference.cv_results_["params"]).astype(float)
    theirs["mse_reference"] = -reference.cv_results_["mean_test_score"]
    merged = ours.table.merge(theirs, on=["C", "gamma"], validate="one_to_one")
    best = theirs.loc[theirs["mse_reference"].idxmin()]
    return pd.DataFrame([{
        "data": "thermal", "n": n, "candidates": len(merged), "folds": 5,
        "svrqp_cpu_s": min(cpu["svrqp"]), "GridSearchCV_cpu_s": min(cpu["GridSearchCV"]),
        "ratio": min(cpu["svrqp"]) / min(cpu["GridSearchCV"]),
        "max_rel_dCVMSE": float(np.max(np.abs(merged["mse"] - merged["mse_reference"])
                                       / merged["mse_reference"])),
        "failed_folds": int(merged["failed_folds"].sum()),
        "best svrqp (C, γ)": f"({ours.best_params['C']:g}, {ours.best_params['gamma']:.3g})",
        "best GridSearchCV (C, γ)": f"({best['C']:g}, {best['gamma']:.3g})",
    }])


def report(table: pd.DataFrame, total_s: float, grid: pd.DataFrame | None = None) -> str:
    """The Markdown page: machine, acceptance per cell, the table."""
    big = table[table["n"] >= 4000]
    lines = [
        "# Small problems and smooth thermal records: the default EpsilonSVR() against libsvm",
        "",
        (__doc__ or "").split("\n\n", 1)[1].split("\n\nUsage")[0].strip(),
        "",
        "## Machine",
        "",
        machine_sentence(machine_info(), package_versions()),
        "",
        f"1 BLAS thread; the machine (2 cores) was shared with other work while this ran. Total "
        f"time {total_s:.0f} s.",
        "",
        "## Acceptance (issue 38)",
        "",
        f"- default ≤ 1.0× libsvm (median ratio): {int((table['ratio'] <= 1.0).sum())} of "
        f"{len(table)} cells; by the fastest fits: {int((table['ratio_min'] <= 1.0).sum())}",
        f"- ≤ 0.5× at n ≥ 4000: {int((big['ratio'] <= 0.5).sum())} of {len(big)} cells",
        f"- within 1e-5·std(y) of the exact reference (Clarabel, polished on its active set): "
        f"{int((table['dev_exact_std'] <= 1e-5).sum())} of "
        f"{int(table['dev_exact_std'].notna().sum())}"
        f" cells (n ≤ {EXACT_MAX_N}); optimality conditions met within 1e-5·std(y) (independent "
        f"numpy check): {int((table['kkt_std'] <= 1e-5).sum())} of {len(table)}; dual objective "
        f"at or below libsvm's at tol 1e-12 (to 1e-12 relative): "
        f"{int((table['objective_rel'] <= 1e-12).sum())} of {len(table)}",
        f"- certified (largest relative residual ≤ 1e-6): "
        f"{int((table['certificate'] <= 1e-6).sum())} of {len(table)}",
        "",
        "## Results",
        "",
        markdown_table(table),
        "",
    ]
    if grid is not None:
        lines += ["## Tuning: 5×5 grid, thermal, n = 200", "", markdown_table(grid), ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default=",".join(map(str, SIZES)))
    parser.add_argument("--data", default=",".join(GENERATORS))
    parser.add_argument("--profile", action="store_true", help="add the stage shares per cell")
    parser.add_argument("--grid", action="store_true", help="add the tuning grid at n = 200")
    parser.add_argument("--out", type=Path, default=RESULTS / "epsilon_svr_small_smooth.md")
    parser.add_argument("--force", action="store_true", help="overwrite --out")
    arguments = parser.parse_args()
    if arguments.out.exists() and not arguments.force:
        raise SystemExit(f"{arguments.out} exists; pass --force to overwrite it")
    start, rows = time.perf_counter(), []
    for n in map(int, arguments.sizes.split(",")):
        for kind in arguments.data.split(","):
            rows.append(run_cell(kind, n, arguments.profile))
            print({key: (f"{value:.3g}" if isinstance(value, float) else value)
                   for key, value in rows[-1].items()}, flush=True)
    table = pd.DataFrame(rows)
    grid = run_grid() if arguments.grid else None
    arguments.out.write_text(report(table, time.perf_counter() - start, grid), encoding="utf-8")
    table.to_csv(arguments.out.with_suffix(".csv"), index=False)


if __name__ == "__main__":
    main()
