"""``svrqp gap``: sim-to-real gap diagnosis (the fixed
command line of ``docs/gap.md``, "The contract").

::

    svrqp gap DATA.csv --target COL --train QUERY
              (--features COL[,COL…] [--model mlr|svr|lssvr] | --prediction COL)
              --candidates COL[,COL…] [--order COL] [--group COL]
              --json OUT.json [--report OUT.html]

``--seed``, ``--surrogates``, ``--local``, ``--local-along`` and ``--force`` are additions: the seed
of the surrogates and bootstrap, how the significance tests draw surrogates
(:mod:`svrqp.gap.within.surrogate_tests`), the localised form of every candidate and the columns
other than the order axis its windows may lie along (:mod:`svrqp.gap.transfer.windows`), and
permission to overwrite existing output files.
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from svrqp import registry
from svrqp.cli._common import BaselineModel, model_option, read_table
from svrqp.exceptions import ProblemError
from svrqp.fleet.record import GapOptions, diagnose_table

REPORT_SUFFIXES = (".html", ".htm", ".md")


def gap(
    data: Path = typer.Argument(..., help="CSV or Parquet table of measurements, one row per "
                                          "sample."),
    target: str = typer.Option(..., "--target", help="Measured column whose gap is diagnosed (e.g. "
                                                     "error_um)."),
    train: str = typer.Option(
        ..., "--train", help="Pandas query selecting the rows the model was built on (e.g. \"batch "
        "== 'x1'\"); the other rows are the real rows where the gap is assessed."),
    features: str = typer.Option(
        None, "--features", help="Comma-separated model inputs; a --model baseline is fitted on "
                                 "the train rows."),
    model: BaselineModel = model_option(BaselineModel, None,
                              f"The baseline fitted with --features (default "
                              f"{registry.baselines()[0]})."),
    prediction: str = typer.Option(
        None, "--prediction", help="Column holding a simulation's prediction (instead of "
                                   "--features)."),
    candidates: str = typer.Option(
        ..., "--candidates", help="Comma-separated measured columns that may carry the unmodelled "
                                  "effect."),
    order: str = typer.Option(
        None, "--order",
        help="Time (min) or position (mm) column; rates and filters run along it."),
    group: str = typer.Option(
        None, "--group", help="Run/batch column; transforms restart and cross-validation is "
                              "blocked per group."),
    json_out: Path = typer.Option(..., "--json", help="Where to write the svrqp.gap/2 JSON."),
    report: Path = typer.Option(
        None, "--report", help="Also write a report: .html (self-contained) or .md (with PNG "
                               "figures beside it)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the surrogate tests and the bootstrap."),
    within_evidence: bool = typer.Option(
        False, "--within-evidence", help="Also test each candidate within the real rows themselves "
        "(what a per-run recalibration would remove: the causes' p_within, within_shrink, "
        "shrink_beyond_base; null without it). It never enters a shrink or the summary, and takes "
        "about a third of the time."),
    surrogates: str = typer.Option(
        "rotation", "--surrogates", help="With --within-evidence: rotation (default) | continuous: "
                                         "rotations made continuous at the seam, safer when the "
                                         "true cause may be missing and candidates drift within a "
                                         "run (less power on slow effects)."),
    jobs: int = typer.Option(1, "--jobs", help="Threads for the within-real-rows tests (-1: one "
                                               "per core); the result does not depend on it."),
    local: bool = typer.Option(
        False, "--local", help="Also try each candidate acting in one window of the --order axis "
        "only (a start-up transient, an acceleration zone, a guideway patch) and name the window."),
    local_along: str = typer.Option(
        None, "--local-along", help="With --local, also try windows along these columns, "
                                    "comma-separated: the rows above or below one of the column's "
                                    "deciles (a sensor that matters only above a spindle speed)."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing output files."),
) -> None:
    """Where the gap between a model and real data lies,
    which unmodelled effect causes it, how far it shrinks."""
    options = GapOptions(
        target=target, train=train, candidates=candidates, features=features,
        model=None if model is None else model.value, prediction=prediction, order=order,
        group=group, seed=seed, within_evidence=within_evidence, surrogates=surrogates,
        local=local, local_along=local_along, jobs=jobs)
    if report is not None and report.suffix.lower() not in REPORT_SUFFIXES:
        raise ProblemError(f"--report: name the file with one of {REPORT_SUFFIXES}, got "
                           f"{report.name!r}")
    outputs = [json_out] + ([report] if report is not None else [])
    existing = [str(path) for path in outputs if path.exists()]
    if existing and not force:  # fail before the work, not after it
        raise FileExistsError(f"output file(s) exist: {existing}; pass --force to overwrite")

    table = read_table(data)
    columns = (TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn())
    with Progress(*columns, transient=True) as progress:
        task = progress.add_task("gap diagnosis", total=1.0)
        result = diagnose_table(
            table, options,
            progress=lambda stage, done: progress.update(task, completed=done, description=stage),
        )
    written = [result.write_json(json_out, force=force)]
    if report is not None:
        if report.suffix.lower() == ".md":
            result.to_markdown(report, force=force)
            written.append(report)
        else:
            written.append(result.to_html(report, force=force))
    typer.echo(result.summary)
    typer.echo("wrote " + ", ".join(str(path) for path in written))


def register(app: typer.Typer) -> None:
    """Add ``svrqp gap`` to the command-line app."""
    app.command("gap")(gap)
