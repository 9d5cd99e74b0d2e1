"""``svrqp fleet``: the gap diagnosis of many records in one run (:mod:`svrqp.fleet`).

::

    svrqp fleet MANIFEST.csv|MANIFEST.toml|'GLOB' --out FOLDER
                [the options of svrqp gap, as every record's defaults]
                [--workers N | --scheduler ADDRESS] [--resume | --force]

Each record's ``svrqp.gap/2`` JSON is written to ``FOLDER/records/NAME.json`` exactly as
``svrqp gap --json`` writes it; the fleet table, the pooled evidence and the HTML page beside.
"""

from __future__ import annotations

import os
from pathlib import Path

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from svrqp import registry
from svrqp.cli._common import BaselineModel, model_option
from svrqp.exceptions import ProblemError


def fleet(
    source: str = typer.Argument(
        ..., help="Manifest (.csv or .toml: one row per record with its path and any of target, "
                  "train, features, model, prediction, candidates, order, group) or a quoted glob "
                  "of record files ('records/*.csv')."),
    out: Path = typer.Option(..., "--out", help="Output folder: records/NAME.json, fleet.csv, "
                                               "pooled.csv, fleet.html."),
    target: str = typer.Option(None, "--target", help="Measured column whose gap is diagnosed."),
    train: str = typer.Option(None, "--train", help="Pandas query selecting the train rows."),
    features: str = typer.Option(None, "--features", help="Comma-separated model inputs."),
    model: BaselineModel = model_option(BaselineModel, None,
                                        f"The baseline fitted with --features (default "
                                        f"{registry.baselines()[0]})."),
    prediction: str = typer.Option(None, "--prediction", help="Column holding a prediction."),
    candidates: str = typer.Option(None, "--candidates", help="Comma-separated candidates."),
    order: str = typer.Option(None, "--order", help="Time (min) or position (mm) column."),
    group: str = typer.Option(None, "--group", help="Run/batch column."),
    seed: int = typer.Option(0, "--seed", help="Seed of every record's surrogate tests."),
    within_evidence: bool = typer.Option(False, "--within-evidence",
                                         help="As svrqp gap --within-evidence."),
    surrogates: str = typer.Option("rotation", "--surrogates", help="As svrqp gap --surrogates."),
    local: bool = typer.Option(False, "--local", help="As svrqp gap --local."),
    local_along: str = typer.Option(None, "--local-along", help="As svrqp gap --local-along."),
    workers: int = typer.Option(
        None, "--workers", help="Processes of a local Dask cluster (default: one per core; 1: "
                                "serially in this process, no Dask needed)."),
    scheduler: str = typer.Option(
        None, "--scheduler", help="Address of an existing Dask scheduler (tcp://host:8786) to "
                                  "run the records on instead of a local cluster."),
    resume: bool = typer.Option(False, "--resume", help="Keep the records of an earlier run in "
                                                        "--out whose input and settings did not "
                                                        "change; diagnose the rest."),
    force: bool = typer.Option(False, "--force", help="Diagnose every record again in an --out "
                                                      "that holds a fleet."),
) -> None:
    """The gap diagnosis of every record of a fleet,
    with a fleet table, pooled evidence and an HTML page."""
    from svrqp.extras import has_extra, require
    from svrqp.fleet import Execution, read_records, run_fleet

    if resume and force:
        raise ProblemError("give --resume or --force, not both")
    if workers is not None and workers < 1:
        raise ProblemError(f"--workers must be at least 1, got {workers}")
    if workers is not None and scheduler is not None:
        raise ProblemError("give --workers (a local cluster) or --scheduler, not both")
    if workers is None:  # one per core where Dask is here, else serially
        workers = (os.cpu_count() or 1) if has_extra("dask") else 1
    if scheduler is not None or workers > 1:
        require("dask", "svrqp fleet on more than one worker")
    defaults = {"target": target, "train": train, "features": features,
                "model": None if model is None else model.value, "prediction": prediction,
                "candidates": candidates, "order": order, "group": group, "seed": seed,
                "within_evidence": within_evidence, "surrogates": surrogates, "local": local,
                "local_along": local_along}
    records = read_records(source)
    columns = (TextColumn("records"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    # Redrawn once a second, not rich's ten: a record takes about a second, and each redraw of a
    # serial run takes the GIL from the record's thread (benchmarks/results/fleet.md).
    with Progress(*columns, transient=True, refresh_per_second=1) as progress:
        task = progress.add_task("records", total=len(records))
        result = run_fleet(records, defaults, out, resume=resume, force=force,
                           execution=Execution(workers=workers, scheduler=scheduler),
                           progress=lambda done, _: progress.update(task, completed=done))
    for _, row in result.failed.iterrows():
        typer.echo(f"record {row['name']} failed: {row['reason']}", err=True)
    counts = result.table["status"].value_counts().to_dict()
    typer.echo(f"{len(result.table)} records: "
               + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())))
    typer.echo(result.pooled.summary())
    typer.echo("wrote " + ", ".join(str(path) for path in result.written))
    if not result.failed.empty:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Add ``svrqp fleet`` to the command-line app."""
    app.command("fleet")(fleet)
