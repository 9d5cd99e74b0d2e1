"""``svrqp gap`` on long records: time and memory against record length, candidates and threads.

The suite's performance case (about 2,000 real rows, 8 candidates, 3 transforms; target ≤ 20 s on
two cores) is recorded by :mod:`gap_suite`. A user with a day-long log at one sample a minute
and a sensor network has ten times the rows and four times the candidates; this measures how
the diagnosis grows towards that, on one and on two threads (``n_jobs``; the report is the
same whatever ``n_jobs`` is, and the table shows the verdicts agree).

Data: the gap suite's thermal/features timing scenario (:func:`gap_suite.timing_case`: MLR on
three node sensors, ``bed_C`` withheld, AR(1) probe noise, one train run) with more and longer
runs, and extra decoy candidates ``blend<i>_C`` — random blends of two node temperatures plus
0.05 °C noise, so correlated with the genuine ones as a sensor network's readings are. Each
case runs in a fresh process so that its peak resident memory (``getrusage``) is its own.

Run: ``python benchmarks/gap_scale.py`` — writes ``benchmarks/results/gap_scale.{csv,md}``
(about 4 minutes on two cores).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gap_suite as gs  # benchmarks/ is not a package: imported from its folder

from svrqp.bench.report import machine_info, machine_sentence, markdown_table, package_versions
from svrqp.gap import GapQuestion, diagnose

RESULTS = Path(__file__).resolve().parent / "results"
CASES = {"short": (5, 480.0, 0), "half day": (10, 720.0, 8), "day": (10, 1440.0, 24)}
"""Case name: (runs, minutes per run, extra decoy candidates)."""
CANDIDATES = ("bed_C", "T5_C", "T8_C", "T9_C", "speed_rpm", "axis_duty_pct", "T1_C", "T4_C")
FEATURES = ("T1_C", "T4_C", "nut_C")
JOBS = (1, 2)


def case_table(name: str) -> tuple[pd.DataFrame, list[str]]:
    """The record and the candidates of case ``name``."""
    runs, minutes, decoys = CASES[name]
    scenario = gs.Scenario("scale", "thermal/features", "withheld", "bed_C", snr=2.0, runs=runs, run_min=minutes,
                           ar=True, seed=99)
    table = gs.case_for(scenario).table
    rng = np.random.default_rng(1)
    candidates = list(CANDIDATES)
    for i in range(decoys):
        table[f"blend{i}_C"] = (rng.uniform() * table["T5_C"] + rng.uniform() * table["T9_C"]
                                + 0.05 * rng.standard_normal(len(table)))
        candidates.append(f"blend{i}_C")
    return table, candidates


def run_one(name: str, jobs: int) -> dict:
    """Diagnose case ``name`` on ``jobs`` threads in this process."""
    table, candidates = case_table(name)
    with threadpool_limits(1):  # threads come from n_jobs alone
        started = time.perf_counter()
        question = GapQuestion(target="error_um", train="run < 1", features=list(FEATURES),
                               candidates=candidates, order="time_min", group="run")
        report = diagnose(table, question, n_jobs=jobs)
        seconds = time.perf_counter() - started
    return {"case": name, "rows": len(table), "real rows": report.n_real, "candidates": len(candidates),
            "threads": jobs, "seconds": seconds,
            "peak RSS (MB)": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "verdict": report.verdict.column or "none",
            "cannot be told apart": ", ".join(report.verdict.ambiguous_with or []) or "–"}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--one", nargs=2, metavar=("CASE", "JOBS"), help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, default=RESULTS, help="Folder for gap_scale.csv and gap_scale.md.")
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(run_one(args.one[0], int(args.one[1]))))
        return 0
    rows = []
    for name in CASES:
        for jobs in JOBS:
            done = subprocess.run([sys.executable, __file__, "--one", name, str(jobs)], check=True,
                                  capture_output=True, text=True)
            rows.append(json.loads(done.stdout.strip().splitlines()[-1]))
            print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    with threadpool_limits(1):  # as in every case's process
        machine = machine_info()
    one = table[table["threads"] == 1].set_index("case")["seconds"]
    table["time / one thread"] = table["seconds"] / table["case"].map(one)
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "gap_scale.csv", index=False)
    same = table.groupby("case")["verdict"].nunique().eq(1).all()
    longest = table[table["case"] == list(CASES)[-1]].set_index("threads")
    text = "\n".join([
        "# svrqp gap — long records: time and memory", "",
        "Generated by `benchmarks/gap_scale.py` (data and method in its docstring); each row one diagnosis in a "
        "fresh process, one BLAS thread.", "",
        markdown_table(table), "",
        (f"On the longest record two threads take {longest.loc[2, 'time / one thread']:.2f} of the time of one. "
         + ("The verdicts agree whatever the number of threads. " if same else
            "**The verdicts differ between thread counts.** ")
         + "Most of the time goes into the surrogates of the lag tests (each surrogate is filtered again at "
           "every time constant); two threads share the memory bandwidth those large arrays need, so the "
           "gain is below two."), "",
        machine_sentence(machine, package_versions()), "",
        "## Limitations", "",
        "One run per row on a machine shared with other work, not isolated from other load; the ratios between "
        "rows of one run are the numbers to read. Peak RSS is the whole process's (Python, the simulated "
        "record and the diagnosis).",
    ]) + "\n"
    (args.out / "gap_scale.md").write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
