"""``svrqp bench``: compare QP backends and formulations
on the SVR problems (see :mod:`svrqp.bench`)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from svrqp.bench.cases import GENERATORS, PROFILES
from svrqp.exceptions import ProblemError


def _names(text: str, option: str) -> tuple[str, ...]:
    names = tuple(name.strip() for name in text.split(",") if name.strip())
    if not names:
        raise ProblemError(f"{option} needs at least one name")
    return names


def _sizes(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(value) for value in _names(text, "--n"))
    except ValueError:
        raise ProblemError(f"--n must be comma-separated integers, got {text!r}") from None


def _gamma(text: str) -> float | str:
    if text == "scale":
        return text
    try:
        return float(text)
    except ValueError:
        raise ProblemError(f"--gamma must be 'scale' or a positive number, got {text!r}") from None


def bench(
    n: str = typer.Option("250,500,1000", "--n", help="Comma-separated sample sizes, run in "
                                                      "ascending order."),
    d: int = typer.Option(10, "--d", help="Number of features of the generated datasets."),
    datasets: str = typer.Option(
        "friedman1", "--datasets", help=f"Comma-separated generated datasets: "
                                        f"{', '.join(GENERATORS)}."),
    kernel: str = typer.Option("rbf", "--kernel", help="Kernel: rbf, linear or poly."),
    C: float = typer.Option(10.0, "--C", help="Box bound C of the SVR dual."),
    epsilon: float = typer.Option(0.1, "--epsilon", help="Half-width of the insensitive tube "
                                                         "(units of standardised y)."),
    gamma: str = typer.Option("scale", "--gamma", help="Kernel gamma (scikit-learn convention) or "
                                                       "'scale'."),
    backends: str = typer.Option(
        "clarabel,osqp,piqp,proxqp,highs", "--backends",
        help="Comma-separated QP backends ('all' for every installed one), and/or dual_ipm "
             "(svrqp's own)."),
    formulations: str = typer.Option(
        "stacked,split", "--formulations",
        help="Comma-separated epsilon-SVR formulations: stacked, split, low_rank, primal (linear "
             "kernel only) for QP backends; dense, auto, low_rank for dual_ipm."),
    ls_svr: bool = typer.Option(False, "--ls-svr/--no-ls-svr", help="Also benchmark the LS-SVR "
                                                                    "linear system."),
    profile: str = typer.Option(
        "default", "--profile", help=f"Accuracy profile: {', '.join(PROFILES)} (requested and "
                                     f"accepted tolerances)."),
    time_limit_s: float = typer.Option(60.0, "--time-limit", help="Per-run time limit in seconds "
                                                                  "(the run is killed)."),
    threads: int = typer.Option(1, "--threads", help="BLAS/OpenMP threads allowed to each run."),
    seed: int = typer.Option(0, "--seed", help="Seed of the generated datasets."),
    output_dir: Path = typer.Option(Path("bench-output"), "--output-dir", help="Folder for "
                                                                               "results.csv, "
                                                                               "results.md and "
                                                                               "results_time_vs_n.png."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing result files."),
) -> None:
    """Run every backend x formulation on generated SVR
    problems; write a CSV, a Markdown report and a plot."""
    from svrqp.bench.report import output_paths, write_outputs  # matplotlib: not needed for --help
    from svrqp.bench.run import BenchConfig, run_benchmark  # the solvers: not needed for --help
    from svrqp.solvers.qp_backends import (
        available_backends,  # imported when the command runs: `--help` stays quick
    )

    chosen_backends = (
        tuple(available_backends()) if backends == "all" else _names(backends, "--backends")
    )
    config = BenchConfig(
        datasets=_names(datasets, "--datasets"), sizes=_sizes(n), d=d, kernel=kernel, C=C,
        epsilon=epsilon, gamma=_gamma(gamma), formulations=_names(formulations, "--formulations"),
        backends=chosen_backends,
        ls_svr=ls_svr, profile=profile, time_limit_s=time_limit_s, threads=threads, seed=seed,
    )
    from svrqp import output

    for path in output_paths(output_dir).values():  # fail before the long run, not after it
        output.check_target(path, force=force)
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn())
    with Progress(*columns, transient=False) as progress:
        task = progress.add_task("benchmark", total=config.n_runs())
        rows = run_benchmark(config,
                             on_run=lambda text: progress.update(task, advance=1, description=text))
    paths = write_outputs(rows, config, output_dir, force=force)
    solved = int(rows["success"].sum())
    typer.echo(
        f"{solved}/{len(rows)} runs succeeded; wrote "
        + ", ".join(str(path) for path in paths.values())
    )


def register(app: typer.Typer) -> None:
    """Add ``svrqp bench`` to the command-line app."""
    app.command("bench")(bench)
