"""Outputs of the solver comparison: machine description, CSV, Markdown table, log-log plot.

The Markdown report states what was measured and on what: CPU, cores, the BLAS libraries and
the kernel (architecture) threadpoolctl reports for each, ``OPENBLAS_CORETYPE``, the threads
each run was allowed, package versions, the configuration, the aggregate and full tables, and a
"Limitations" paragraph.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

# A Figure of its own, never pyplot's global state: the backend of a notebook or GUI stays as it is.
from matplotlib.figure import Figure

from svrqp import output
from svrqp.bench.cases import PROFILES
from svrqp.bench.evaluate import aggregate, ratios_to_reference
from svrqp.bench.run import BenchConfig
from svrqp.solvers.qp_backends import BACKENDS

#: Packages whose versions every report records (backends are added from :data:`BACKENDS`).
CORE_PACKAGES = ("svrqp", "numpy", "scipy", "scikit-learn", "qpsolvers", "threadpoolctl")

OUTPUT_SUFFIXES = {"csv": ".csv", "markdown": ".md", "plot": "_time_vs_n.png"}


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_info() -> dict[str, Any]:
    """CPU, core counts, BLAS/OpenMP libraries with their
    kernel and threads, and ``OPENBLAS_CORETYPE``."""
    from threadpoolctl import threadpool_info

    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "cpu": _cpu_model(),
        "cores_logical": os.cpu_count(),
        "cores_usable": usable,
        "platform": platform.platform(),
        "python": platform.python_version(),
        "OPENBLAS_CORETYPE": os.environ.get("OPENBLAS_CORETYPE", "unset"),
        "thread_pools": [
            {key: pool.get(key)
             for key in ("user_api", "internal_api", "version", "architecture", "num_threads")}
            | {"library": Path(pool["filepath"]).name}
            for pool in threadpool_info()
        ],
    }


def package_versions(backends: set[str] | None = None) -> dict[str, str]:
    """Installed versions of the core packages and of the given backends' packages."""
    names = list(CORE_PACKAGES) + [BACKENDS[name].package for name in sorted(backends or ())
                                   if name in BACKENDS]
    versions = {}
    for name in dict.fromkeys(names):
        try:
            versions[name] = version(name)
        except PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def machine_sentence(machine: dict[str, Any], versions: dict[str, str]) -> str:
    """One paragraph for a results file: CPU, usable cores, platform, Python, ``OPENBLAS_CORETYPE``,
    the BLAS libraries with their kernel and threads
    (from :func:`machine_info`) and ``versions``."""
    blas = ", ".join(f"{pool['internal_api']} {pool['version']} ({pool['architecture']}, "
                     f"{pool['num_threads']} thread(s))" for pool in machine["thread_pools"]
                     if pool["user_api"] == "blas")
    return (f"Machine: {machine['cpu']}, {machine['cores_usable']} usable cores, "
            f"{machine['platform']}, Python {machine['python']}, OPENBLAS_CORETYPE = "
            f"{machine['OPENBLAS_CORETYPE']}. BLAS (threadpoolctl): {blas}. Versions: "
            "" + ", ".join(f"{name} {value}" for name, value in versions.items()) + ".")


def markdown_table(table: pd.DataFrame, float_format: str = "{:.3g}") -> str:
    """A GitHub Markdown table (no extra dependency): floats in ``float_format``."""
    def cell(value: Any) -> str:
        if isinstance(value, (float, np.floating)):
            return "" if np.isnan(value) else float_format.format(value)
        return str(value).replace("|", "\\|")

    lines = ["| " + " | ".join(map(str, table.columns)) + " |", "|" + "---|" * len(table.columns)]
    lines += ["| " + " | ".join(cell(value) for value in row) + " |"
              for row in table.itertuples(index=False)]
    return "\n".join(lines)


LIMITATIONS = (
    "Every run is a fresh child process forked from the harness with the backends already "
    "imported, so import time is excluded but cold caches are not (no warm-up run). Times include "
    "svrqp's own wrapper work: building the Gram matrix and the QP, converting matrices for the "
    "backend (build time), and computing the certificates after the solve (total time). libsvm "
    "computes kernel entries inside its solver, so its build time is zero and its solve time "
    "includes the kernel. All runs share the same BLAS thread limit, and the machine may be shared "
    "with other work: compare ratios measured in the same report, not absolute times across "
    "reports. Success only means that the certificates meet the profile's tolerance; the objective "
    "gap and prediction difference against the reference (libsvm for epsilon-SVR, "
    "numpy.linalg.solve for LS-SVR) are reported separately, and the reference itself stops at its "
    "own tolerance. Failed and skipped runs are charged the time limit in the shifted geometric "
    "means. Backends that need a positive definite P get a tiny diagonal (pd_regularisation) whose "
    "effect on the objective is the pd_objective_shift column. Methods that return only (beta, b) "
    "— libsvm and svrqp's dual_ipm — are certified on the stacked dual with multipliers rebuilt "
    "from the model (svrqp.bench.outcomes.beta_certificates): this is the true primal-dual gap at "
    "that b. libsvm stops when its maximal violating pair is below tol, which leaves a relative "
    "gap of about 1e-6 to 5e-6 at tol = 1e-8 on these problems, so under the default profile it is "
    "flagged unsuccessful and charged the time limit in the aggregate; its measured times are in "
    "the ratio table and the full table. Low-rank methods are certified on the factored problem "
    "they solve; approximation_error (relative trace of K - LL^T) and the objective and prediction "
    "differences show what the approximation costs."
)


def markdown_report(rows: pd.DataFrame, config: BenchConfig, machine: dict[str, Any],
                    versions: dict[str, str], title: str = "svrqp solver comparison",
                    extra_sections: Sequence[str] = ()) -> str:
    """The full Markdown report of one benchmark run
    (``extra_sections`` go before the full table)."""
    profile = PROFILES[config.profile]
    summary = aggregate(rows, config.time_limit_s, config.shift_s)
    pools = pd.DataFrame(machine["thread_pools"])
    shown = ["dataset", "n", "method", "status", "success", "build_time_s", "solve_time_s",
             "total_time_s",
             "iterations", "primal_residual", "dual_residual", "duality_gap", "objective_gap_rel",
             "prediction_diff_rel", "support_agreement"]
    return "\n\n".join([
        f"# {title}",
        "## Configuration\n\n" + "\n".join([
            f"- datasets: {', '.join(config.datasets)}; n = "
            f"{', '.join(map(str, sorted(config.sizes)))}; d = {config.d}; kernel = "
            f"{config.kernel}; C = {config.C:g}; epsilon = {config.epsilon:g}; gamma = "
            f"{config.gamma}",
            f"- profile `{profile.name}`: requested tol = {profile.tol:g}, success when every "
            f"relative certificate <= {profile.residual_tol:g}",
            f"- time limit {config.time_limit_s:g} s per run; shifted geometric mean with shift "
            f"{config.shift_s:g} s; {config.threads} BLAS/OpenMP thread(s) per run",
        ]),
        "## Machine\n\n" + "\n".join([
            f"- CPU: {machine['cpu']} ({machine['cores_usable']} usable of "
            f"{machine['cores_logical']} logical cores)",
            f"- {machine['platform']}, Python {machine['python']}",
            f"- OPENBLAS_CORETYPE: {machine['OPENBLAS_CORETYPE']}",
        ]) + "\n\nThread pools (threadpoolctl; `architecture` is the BLAS kernel in use; "
             "`num_threads` is the harness's default, each run is limited to the threads stated "
             "above):\n\n" + markdown_table(pools),
        "## Package versions\n\n"
        + "\n".join(f"- {name} {value}" for name, value in versions.items()),
        "## Aggregate (shifted geometric mean of total time, failures at the time limit)\n\n"
        + markdown_table(summary),
        "## Fastest exact method against the reference\n\nExact: success, objective at most 1e-8 "
        "(relative) above the reference's, predictions within 1e-4·std(y) of the reference's; "
        "ratio = its total time / the reference's, both from this run.\n\n"
        + markdown_table(ratios_to_reference(rows)),
        *extra_sections,
        "## All runs\n\n" + markdown_table(rows[shown]),
        "## Limitations\n\n" + LIMITATIONS,
    ]) + "\n"


def plot_time_vs_n(rows: pd.DataFrame, path: Path) -> None:
    """Total time against n on log-log axes, one line per
    method, one panel per dataset (successes only)."""
    datasets = list(dict.fromkeys(rows["dataset"]))
    figure = Figure(figsize=(6.5 * len(datasets), 4.8))
    axes = figure.subplots(1, len(datasets), squeeze=False)
    for axis, dataset in zip(axes[0], datasets, strict=False):
        subset = rows[(rows["dataset"] == dataset) & rows["success"]]
        for method, runs in subset.groupby("method", sort=False):
            runs = runs.sort_values("n")
            axis.plot(runs["n"], runs["total_time_s"], marker="o", label=method)
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlabel("number of samples n")
        axis.set_ylabel("total time per run (s)")
        axis.set_title(f"{dataset} (successful runs)")
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize=7, ncol=2)
    figure.tight_layout()
    figure.savefig(path, dpi=120)


def output_paths(output_dir: Path, stem: str = "results") -> dict[str, Path]:
    """Where :func:`write_outputs` writes each file:
    ``stem.csv``, ``stem.md``, ``stem_time_vs_n.png``."""
    return {kind: Path(output_dir) / f"{stem}{suffix}" for kind, suffix in OUTPUT_SUFFIXES.items()}


def write_outputs(rows: pd.DataFrame, config: BenchConfig, output_dir: Path, *, force: bool = False,
                  stem: str = "results", title: str = "svrqp solver comparison",
                  extra_sections: Sequence[str] = ()) -> dict[str, Path]:
    """Write the CSV, the Markdown report and the plot into ``output_dir``.

    Raises
    ------
    FileExistsError
        When one of the files exists and ``force`` is false
        (a user's file is never overwritten silently).
    ProblemError
        When one of the paths is a FIFO, a folder or a device (:mod:`svrqp.output`).
    """
    paths = output_paths(output_dir, stem)
    # svrqp.output: links replaced, never written through; FIFOs refused
    for path in paths.values():
        output.check_target(path, force=force)
    with output.replacing(paths["csv"], force=force) as temporary:
        rows.to_csv(temporary, index=False)
    backends = set(rows["backend"])
    output.write_text(paths["markdown"],
                      markdown_report(rows, config, machine_info(), package_versions(backends),
                                                         title, extra_sections), force=force)
    with output.replacing(paths["plot"], force=force) as temporary:
        plot_time_vs_n(rows, temporary)
    return paths
