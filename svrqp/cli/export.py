"""``svrqp export``: write a model as auditable
JSON, the papers' CSV coefficient table, or C source.

Two inputs, told apart by the suffix of INPUT:

* a model file (``.json``, schema ``svrqp.model/1``) — verified, then converted to ``--format``;
* a data table (``.csv``, ``.parquet``) — a model of kind ``--model`` is fitted on ``--features``
  → ``--target`` first, then exported with the data's hash and the scikit-learn cross-check.
"""

from __future__ import annotations

from pathlib import Path

import typer

from svrqp.cli._common import (
    COVERAGE_HELP,
    GROUP_HELP,
    INTERVAL_HELP,
    SOLVER_HELP,
    FitModel,
    model_option,
)
from svrqp.exceptions import ProblemError

#: The output formats, as ``--help`` lists them (kept light: svrqp.export loads scikit-learn).
FORMAT_CHOICES = "json, csv, c"
MODEL_SUFFIXES = {".json"}
DATA_SUFFIXES = {".csv", ".parquet", ".pq"}


def export_command(
    source: Path = typer.Argument(..., help="A model file (.json, svrqp.model/1) to convert, or a "
                                            "data "
                                            "table (.csv/.parquet) to fit a model on and export."),
    out: Path = typer.Option(..., "--out", "-o", help="Output file (.json, .csv, .c) or, for C, a "
                                                      "directory that receives svrqp_model.c and "
                                                      "svrqp_model.h."),
    format: str = typer.Option(None, "--format", "-f", help=f"One of {FORMAT_CHOICES}; default: "
                                                            "from the suffix of --out."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing output files."),
    target: str = typer.Option(None, "--target", help="Data tables: the target column (unit in its "
                                                      "name, e.g. error_um)."),
    features: str = typer.Option(None, "--features", help="Data tables: input columns, "
                                                          "comma-separated (e.g. T7_C,T9_C)."),
    model: FitModel = model_option(FitModel, "svr", "Data tables: the model to fit."),
    C: float = typer.Option(1.0, "--C", help="svr/lssvr: the regularisation weight C."),
    epsilon: float = typer.Option(0.1, "--epsilon", help="svr: half-width of the ε-tube, in target "
                                                         "units."),
    gamma: str = typer.Option("scale", "--gamma", help="svr/lssvr: RBF gamma (scikit-learn "
                                                       "convention, = S0's g = 1/σ²; S4's σ gives "
                                                       "1/(2σ²)), or 'scale'/'auto'."),
    degree: int = typer.Option(5, "--degree", help="poly: polynomial degree (one input)."),
    forgetting: float = typer.Option(1.0, "--forgetting",
                                     help="rls: forgetting factor λ in (0, 1]."),
    solver: str = typer.Option("auto", "--solver", help=SOLVER_HELP),
    standardize: bool = typer.Option(False, "--standardize", help="Data tables: standardise the "
                                                                  "inputs "
                                                                  "first (recorded in the file)."),
    coverage: float = typer.Option(None, "--coverage", help="Data tables: " + COVERAGE_HELP),
    group: str = typer.Option(None, "--group", help="Data tables: " + GROUP_HELP),
    interval: str = typer.Option("absolute", "--interval", help="Data tables: " + INTERVAL_HELP),
) -> None:
    """Export a model as svrqp.model/1 JSON, a CSV coefficient table (S0 Table 1) or C source."""
    model = model.value
    # Imported when the command runs: `svrqp export --help` loads no scikit-learn.
    from rich.console import Console
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from svrqp.cli._common import (
        make_estimator,
        parse_gamma,
        read_table,
        split_columns,
    )
    from svrqp.cli._guard import (
        describe_interval,
        fit_guarded,
        group_labels,
        guarded_or_plain,
    )
    from svrqp.export import build_document, read_document, write

    suffix = source.suffix.lower()
    data_options = {"--target": target, "--features": features, "--coverage": coverage,
                    "--group": group}
    console = Console(stderr=True)
    if suffix in MODEL_SUFFIXES:
        given = [name for name, value in data_options.items() if value is not None]
        if given:
            raise ProblemError(f"{', '.join(given)} only apply when SOURCE is a data table, not a "
                               f"model file")
        document = read_document(source)  # verified: refused unless every check passes
    elif suffix in DATA_SUFFIXES:
        if target is None or features is None:
            raise ProblemError("a data table needs --target and --features")
        table = read_table(source)
        columns = split_columns(features, table, "--features", numeric=True)
        split_columns(target, table, "--target", numeric=True)
        estimator = make_estimator(model, C=C, epsilon=epsilon, gamma=parse_gamma(gamma),
                                   degree=degree, forgetting=forgetting, solver=solver)
        fitted_model = guarded_or_plain(estimator, coverage, group, interval,
                                        standardize=standardize)
        groups = group_labels(table, group)
        X, y = table[columns], table[target]
        with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                      console=console, transient=True) as progress:
            task = progress.add_task(f"fitting {model} on {len(table)} rows", total=None)
            fit_guarded(fitted_model, X, y, groups)
            progress.update(task, description="cross-checking against the reference and hashing")
            document = build_document(fitted_model, X, y)
    else:
        raise ProblemError(f"SOURCE must be a model file (.json) or a data table (.csv, .parquet), "
                           f"got {source}")
    for path in write(document, out, format, force=force):
        typer.echo(f"wrote {path}")
    if "interval" in document:
        typer.echo(describe_interval(document["interval"]))
    cross_check = document["cross_check"]
    if cross_check is not None:
        typer.echo(f"cross-check vs {cross_check['reference']}: max |Δprediction| = "
                   f"{cross_check['max_abs_deviation']:.3g} (std of target "
                   f"{cross_check['target_std']:.3g})")


def register(app: typer.Typer) -> None:
    """Add ``svrqp export`` to ``app``."""
    app.command("export")(export_command)
