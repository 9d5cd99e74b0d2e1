"""Speed of the exported C evaluator for a model of S0's size (56 support vectors, 2 inputs).

S4 runs its compensation in a 10 ms control thread and budgets ~1 ms for the regression; this
measures how much of a 1 ms cycle one ``svrqp_predict`` call takes.

The model: an RBF LS-SVR (every training point is a support vector, so 56 rows give exactly 56)
with S0's kernel width g = 0.125 on (T7_C, T9_C) → error_um, fitted on 56 evenly spaced rows of
the simulated summer batch x1 (``svrqp.datasets.build.miao2013``). The evaluator's cost depends
only on the number of support vectors and inputs, not on the coefficients' values.

Two measurements, each with ``gcc -O2``:

* throughput — a loop of 2·10⁶ calls over 1,000 distinct inputs (best and median of 7 repeats);
* latency — 10⁵ individually timed calls (``clock_gettime``; includes the timer's own ~20 ns):
  median, 99.9th percentile and maximum.

Run: ``.venv/bin/python benchmarks/c_predict_speed.py`` → ``benchmarks/results/c_predict_speed.{json,md}``.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from svrqp import LSSVR, __version__
from svrqp.export import build_document, write
from svrqp.datasets.build import miao2013

N_SUPPORT = 56
RESULTS = Path(__file__).resolve().parent / "results"
CFLAGS = ["-std=c99", "-O2", "-Wall", "-Werror"]

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "svrqp_model.h"

#define N_POINTS 1000
#define N_CALLS 2000000L
#define N_REPEATS 7
#define N_TIMED 100000L

static double now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return 1e9 * (double)t.tv_sec + (double)t.tv_nsec;
}

static int compare(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(void)
{
    static double points[N_POINTS][SVRQP_N_INPUTS];
    static double latency[N_TIMED];
    double throughput[N_REPEATS], sink = 0.0;
    long i;
    int j, r;
    for (i = 0; i < N_POINTS; ++i)
        for (j = 0; j < SVRQP_N_INPUTS; ++j)
            if (scanf("%lf", &points[i][j]) != 1) return 1;
    for (r = 0; r < N_REPEATS; ++r) {
        const double start = now_ns();
        for (i = 0; i < N_CALLS; ++i) sink += svrqp_predict(points[i % N_POINTS]);
        throughput[r] = (now_ns() - start) / (double)N_CALLS;
    }
    for (i = 0; i < N_TIMED; ++i) {
        const double start = now_ns();
        sink += svrqp_predict(points[i % N_POINTS]);
        latency[i] = now_ns() - start;
    }
    qsort(throughput, N_REPEATS, sizeof throughput[0], compare);
    qsort(latency, N_TIMED, sizeof latency[0], compare);
    printf("{\"ns_per_call_best\": %.3f, \"ns_per_call_median\": %.3f, \"latency_ns_median\": %.1f, "
           "\"latency_ns_p999\": %.1f, \"latency_ns_max\": %.1f, \"sink\": %.17g}\n",
           throughput[0], throughput[N_REPEATS / 2], latency[N_TIMED / 2],
           latency[(long)(0.999 * N_TIMED)], latency[N_TIMED - 1], sink);
    return 0;
}
"""


def s0_sized_model():
    """LS-SVR, RBF g = 0.125 (S0), on 56 evenly spaced rows of batch x1: 56 support vectors."""
    x1 = miao2013().query("batch == 'x1'")
    rows = x1.iloc[np.linspace(0, len(x1) - 1, N_SUPPORT).round().astype(int)]
    X, y = rows[["T7_C", "T9_C"]], rows["error_um"]
    model = LSSVR(C=100.0, gamma=0.125).fit(X, y)
    return model, X, y, x1[["T7_C", "T9_C"]]


def cpu_model() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown"


def python_latency_ns(model, X) -> float:
    """Median time of one ``model.predict`` call on one row (for comparison)."""
    row = X.iloc[[0]]
    times = []
    for _ in range(200):
        start = time.perf_counter_ns()
        model.predict(row)
        times.append(time.perf_counter_ns() - start)
    return float(np.median(times))


def main() -> None:
    model, X, y, inputs = s0_sized_model()
    document = build_document(model, X, y)
    assert len(document["model"]["dual_coef"]) == N_SUPPORT
    points = inputs.iloc[np.linspace(0, len(inputs) - 1, 1000).round().astype(int)].to_numpy()
    with tempfile.TemporaryDirectory() as directory:
        directory = Path(directory)
        source, _ = write(document, directory)
        (directory / "bench.c").write_text(HARNESS)
        binary = directory / "bench"
        subprocess.run(["gcc", *CFLAGS, "-o", str(binary), str(directory / "bench.c"), str(source), "-lm"],
                       check=True)
        text = "\n".join(" ".join(repr(float(v)) for v in row) for row in points)
        measured = json.loads(subprocess.run([str(binary)], input=text, capture_output=True, text=True,
                                             check=True).stdout)
    measured.pop("sink")
    gcc = subprocess.run(["gcc", "--version"], capture_output=True, text=True, check=True).stdout.splitlines()[0]
    result = {
        "model": {"kind": document["kind"], "n_support": N_SUPPORT, "n_inputs": 2, "kernel": "rbf",
                  "gamma": 0.125},
        **measured,
        "predictions_per_second": 1e9 / measured["ns_per_call_best"],
        "share_of_1ms_cycle_p999": measured["latency_ns_p999"] / 1e6,
        "python_predict_one_row_ns_median": python_latency_ns(model, X),
        "machine": {"cpu": cpu_model(), "cores_visible": os.cpu_count(), "os": platform.platform(),
                    "compiler": gcc, "cflags": " ".join(CFLAGS), "svrqp": __version__,
                    "note": "shared 2-core development machine; other jobs were running"},
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "c_predict_speed.json").write_text(json.dumps(result, indent=2) + "\n")
    (RESULTS / "c_predict_speed.md").write_text(
        "# Exported C evaluator: speed for a 56-support-vector model (S0's size)\n\n"
        f"Model: RBF LS-SVR, 2 inputs (T7_C, T9_C), {N_SUPPORT} support vectors, gamma = 0.125; "
        f"`svrqp_predict` from `svrqp export --format c`, `gcc {' '.join(CFLAGS)}`.\n\n"
        "| measure | value |\n|---|---|\n"
        f"| time per call, loop (best of 7) | {measured['ns_per_call_best']:.0f} ns |\n"
        f"| time per call, loop (median of 7) | {measured['ns_per_call_median']:.0f} ns |\n"
        f"| predictions per second | {result['predictions_per_second']:.3g} |\n"
        f"| single-call latency: median / 99.9 % / max | {measured['latency_ns_median']:.0f} / "
        f"{measured['latency_ns_p999']:.0f} / {measured['latency_ns_max']:.0f} ns |\n"
        f"| 99.9 % latency as a share of a 1 ms cycle (S4) | {100 * result['share_of_1ms_cycle_p999']:.3f} % |\n"
        f"| for comparison: Python `model.predict` on one row (median) | "
        f"{result['python_predict_one_row_ns_median'] / 1e3:.0f} μs |\n\n"
        f"Machine: {result['machine']['cpu']}, {result['machine']['cores_visible']} cores visible, "
        f"{result['machine']['os']}, {gcc}. Shared development machine with other jobs running: the "
        "maximum latency is the OS preempting the process (milliseconds when it happens), not the "
        "evaluator; a controller runs it in a real-time thread.\n\n"
        "Limitations: one model size and one compiler; no real-time OS; the timer's own cost "
        "(~20 ns) is inside the latency figures.\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
