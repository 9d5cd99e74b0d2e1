"""Size of the between-run t-test that decides run-level causes at five to eight runs.

When no ordering of a run-level candidate's levels can reach Benjamini–Hochberg's first threshold
(:func:`svrqp.gap.transfer.between.permutation_floor`), the transfer ranking takes the p-value of
the t-test of :func:`svrqp.gap.transfer.between.between_run_test` instead of a permutation's. A
parametric test is only as good as its size, so this script measures it on null records, where
nothing the candidates carry reaches the target:

``t-test alone``
    the raw test on :data:`N_DRAWS` null draws per number of real runs (four to seven): residual = a
    profile along each
    run and an offset that differ from run to run at random, plus AR(1) noise within runs; the
    candidate's run levels independent of it, at two levels (ties) or all distinct. Its rejection
    rate at α = 0.05 should be at most 0.05.
``engine``
    :data:`N_RECORDS` whole ``svrqp gap`` diagnoses of such null records in prediction mode (five to
    eight runs: one train run, the real runs' run-to-run variation explained by no candidate; three
    run-level candidates and one that moves within runs). Any verdict is a false attribution;
    the target is at most 0.05.

Run: ``python benchmarks/gap_run_level_size.py [--jobs N] [--records N]``; writes
``benchmarks/results/gap_run_level_size.{csv,md}``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from svrqp.gap import GapQuestion, diagnose
from svrqp.gap.transfer.between import between_run_test, run_level_bank

RESULTS = Path(__file__).resolve().parent / "results"
RUNS = (5, 6, 7, 8)
"""Numbers of runs measured: one train run, the others real (the t-test's observations)."""
ROWS_PER_RUN = 60
N_DRAWS = 1000
"""Null draws of the t-test alone, per number of runs."""
N_RECORDS = 200
"""Null records diagnosed by the engine."""
ALPHA = 0.05
AR_PHI = 0.8
RUN_LEVEL = ("load_kg", "axis_C", "ambient_C")
"""The null records' run-level candidates (``humidity_pct`` moves within runs)."""


def _residual(rng: np.random.Generator, n_runs: int, spread: float) -> np.ndarray:
    """A run-to-run profile and offset at random (scale ``spread``) plus AR(1) noise within runs."""
    u = np.linspace(-1.0, 1.0, ROWS_PER_RUN)
    out = []
    for _ in range(n_runs):
        noise = np.empty(ROWS_PER_RUN)
        noise[0] = rng.normal()
        for k in range(1, ROWS_PER_RUN):
            noise[k] = AR_PHI * noise[k - 1] + np.sqrt(1 - AR_PHI**2) * rng.normal()
        out.append(spread * (rng.normal() + rng.normal() * u + rng.normal() * (1.5 * u**2 - 0.5)) + noise)
    return np.concatenate(out)


def _levels(rng: np.random.Generator, n_runs: int, ties: bool) -> np.ndarray:
    """Run levels of a candidate: two loads (ties) or all distinct."""
    if ties:
        levels = np.array([10.0, 40.0])[rng.permutation(np.arange(n_runs) % 2)]
    else:
        levels = rng.uniform(15.0, 35.0, n_runs)
    return levels


def ttest_draw(seed: int, n_runs: int, ties: bool) -> float:
    """One null p-value of the between-run t-test (prediction-mode design: intercept only)."""
    rng = np.random.default_rng(seed)
    groups = np.repeat(np.arange(n_runs), ROWS_PER_RUN)
    r = _residual(rng, n_runs, spread=2.0)
    x = np.repeat(_levels(rng, n_runs, ties), ROWS_PER_RUN) + 0.01 * rng.normal(size=groups.size)
    t = np.tile(np.arange(ROWS_PER_RUN, dtype=float), n_runs)
    result = between_run_test(r, np.ones((groups.size, 1)), groups, run_level_bank("x", x, t, groups))
    return result.p_value if result.robust else 1.0


def null_record(seed: int, n_runs: int) -> pd.DataFrame:
    """A null record of ``n_runs`` runs: one train run, real runs whose run-to-run variation no candidate explains."""
    rng = np.random.default_rng(seed)
    groups = np.repeat(np.arange(n_runs), ROWS_PER_RUN)
    spread = np.repeat(np.r_[0.3, np.full(n_runs - 1, 3.0)], ROWS_PER_RUN)
    residual = _residual(rng, n_runs, spread=1.0) * spread / spread.mean()
    prediction = 5.0 * np.sin(np.tile(np.linspace(0, 3, ROWS_PER_RUN), n_runs))
    humidity = np.empty(groups.size)  # a stationary reading that moves within runs (AR(1), not a random walk)
    humidity[0] = rng.normal()
    for k in range(1, groups.size):
        humidity[k] = 0.95 * humidity[k - 1] + np.sqrt(1 - 0.95**2) * rng.normal()
    return pd.DataFrame({
        "time_min": np.tile(np.arange(ROWS_PER_RUN, dtype=float), n_runs),
        "run": [f"r{g}" for g in groups],
        "prediction_um": prediction,
        "error_um": prediction + residual,
        "load_kg": np.repeat(_levels(rng, n_runs, ties=True), ROWS_PER_RUN),
        "axis_C": np.repeat(_levels(rng, n_runs, ties=False), ROWS_PER_RUN) + 0.01 * rng.normal(size=groups.size),
        "ambient_C": np.repeat(rng.uniform(18, 24, n_runs), ROWS_PER_RUN),
        "humidity_pct": 50 + 2 * humidity,
    })


def diagnose_null(seed: int, n_runs: int) -> dict:
    """Diagnose one null record; any verdict is a false attribution."""
    table = null_record(seed, n_runs)
    question = GapQuestion(target="error_um", train="run == 'r0'", prediction="prediction_um",
                           candidates=["load_kg", "axis_C", "ambient_C", "humidity_pct"], order="time_min",
                           group="run")
    started = time.perf_counter()
    report = diagnose(table, question, seed=seed)
    by_t = [c for c in report.causes if c.note and "t-test" in c.note]
    return {"seed": seed, "runs": n_runs, "gap_detected": report.gap_detected, "verdict": report.verdict.column,
            "verdict_run_level": report.verdict.column in RUN_LEVEL, "t_tested": len(by_t),
            "runtime_s": time.perf_counter() - started}


def report_text(draws: pd.DataFrame, records: pd.DataFrame) -> str:
    lines = ["# Size of the between-run t-test (run-level causes at five to eight runs)", "",
             "Generated by `benchmarks/gap_run_level_size.py`; simulated null data (nothing the candidates carry "
             "reaches the target), fixed seeds.", "",
             f"## The t-test alone ({N_DRAWS} null draws per cell; rejection rate at α = {ALPHA})", "",
             "| real runs | levels | rejection rate | target |", "|---|---|---|---|"]
    for (runs, ties), part in draws.groupby(["real_runs", "ties"]):
        rate = float((part.p < ALPHA).mean())
        lines.append(f"| {runs} | {'two (ties)' if ties else 'distinct'} | {rate:.3f} | ≤ {ALPHA} |")
    false = int(records.verdict.notna().sum())
    lines += ["", f"## The engine ({len(records)} null records diagnosed by `svrqp.gap.diagnose`)", "",
              "| runs (one train) | records | with a gap | causes decided by the t-test | verdicts (false) | of them "
              "run-level |", "|---|---|---|---|---|---|"]
    for runs, part in records.groupby("runs"):
        lines.append(f"| {runs} | {len(part)} | {int(part.gap_detected.sum())} | {int(part.t_tested.sum())} | "
                     f"{int(part.verdict.notna().sum())} | {int(part.verdict_run_level.sum())} |")
    lines += ["", f"False attribution: {false} of {len(records)} records ({false / len(records):.3f}; target ≤ "
              f"{ALPHA}); naming a run-level candidate: {int(records.verdict_run_level.sum())}. Median diagnosis "
              f"{records.runtime_s.median():.1f} s, one process on a shared 2-core machine.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--records", type=int, default=N_RECORDS)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    draws = pd.DataFrame([{"real_runs": runs - 1, "ties": ties,
                           "p": ttest_draw(10_000 * runs + 2 * i + ties, runs - 1, ties)}
                          for runs in RUNS for ties in (False, True) for i in range(N_DRAWS)])
    jobs = [(900_000 + i, RUNS[i % len(RUNS)]) for i in range(args.records)]
    records = pd.DataFrame(Parallel(n_jobs=args.jobs, verbose=5)(delayed(diagnose_null)(s, k) for s, k in jobs))
    args.out.mkdir(parents=True, exist_ok=True)
    records.to_csv(args.out / "gap_run_level_size.csv", index=False)
    text = report_text(draws, records)
    (args.out / "gap_run_level_size.md").write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
