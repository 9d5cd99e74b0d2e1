"""``svrqp fit``: fit one model on a table and report its coefficients and residuals.

The rows selected by ``--train`` are fitted; the residual metrics of the papers (RMS, standard
deviation, max |dev|, mean |dev|, peak-to-peak) are printed for them and for the other rows. For
``rls`` the other rows are also run through S3's on-line loop (predict, compensate, update).
With ``--coverage`` the model is wrapped in :class:`svrqp.Guarded` (calibration folds by
``--group``) and the interval's coverage and the share of rows outside the domain are printed too.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.console import Console
from rich.table import Table

from svrqp.cli._common import (
    COVERAGE_HELP,
    GROUP_HELP,
    INTERVAL_HELP,
    SOLVER_HELP,
    FitModel,
    model_option,
    select_train_rows,
)
from svrqp.exceptions import ProblemError
from svrqp.units import split_unit

if TYPE_CHECKING:
    import numpy as np


def _print_linear(console: Console, estimator) -> None:
    table = Table(title="coefficients")
    for column in ("name", "value", "unit"):
        table.add_column(column, justify="right" if column == "value" else "left")
    for row in estimator.coefficient_table().itertuples():
        table.add_row(row.name, f"{row.value:.6g}", row.unit)
    console.print(table)
    typer.echo(estimator.to_latex())


def _print_polynomial(console: Console, estimator, target: str) -> None:
    table = Table()
    table.add_column("m", justify="right")
    table.add_column("Legendre c_m", justify="right")
    for m, value in enumerate(estimator.legendre_coef_):
        table.add_row(str(m), f"{value:.6g}")
    console.print(table)
    terms = " ".join(f"{'-' if value < 0 else '+'} {abs(value):.6g}·P{m}(u)"
                     for m, value in enumerate(estimator.legendre_coef_))
    low, high = estimator.domain_
    typer.echo(f"{target} = {terms.removeprefix('+ ')},  u = (2x - {low:g} - {high:g}) / "
               f"{high - low:g}")


def _print_model(console: Console, fitted, target: str) -> None:
    """Coefficient table and formula of a linear model, the polynomial's basis, or the SVR."""
    estimator = fitted.steps[-1][1] if hasattr(fitted, "steps") else fitted
    if hasattr(estimator, "coefficient_table"):
        _print_linear(console, estimator)
    elif hasattr(estimator, "legendre_coef_"):
        _print_polynomial(console, estimator, target)
    else:
        typer.echo(
            f"{len(estimator.support_)} support vectors, b = {estimator.intercept_[0]:.6g}, "
            f"gamma = {estimator.gamma_:.6g}"
            + (" (standardised inputs)" if fitted is not estimator else "")
        )


def _metrics_table(rows: list[tuple[str, np.ndarray]], unit: str) -> Table:
    from svrqp.compensate import residual_metrics

    caption = ("online: the other rows through S3's loop (predict, then update the model)"
               if any(label == "online" for label, _ in rows) else None)
    table = Table(title=f"residuals ({unit or 'target units'})", caption=caption)
    for column in ("rows", "n", "rms", "std", "max |dev|", "mean |dev|", "peak-to-peak"):
        table.add_column(column, justify="left" if column == "rows" else "right")
    for label, residual in rows:
        metrics = residual_metrics(residual)
        table.add_row(label, str(residual.size), *(f"{value:.4g}" for value in (
            metrics.rms_um, metrics.std_um, metrics.max_abs_um, metrics.mean_abs_um,
            metrics.peak_to_peak_um)))
    return table


def fit_command(
    data: Path = typer.Argument(..., help="CSV or Parquet table with the target and feature "
                                          "columns."),
    target: str = typer.Option(..., "--target", help="Column to predict (unit in its name, e.g. "
                                                     "error_um)."),
    features: str = typer.Option(..., "--features", help="Comma-separated input columns (e.g. "
                                                         "T7_C,T9_C)."),
    model: FitModel = model_option(FitModel, "mlr"),
    train: str = typer.Option(None, "--train", help="Filter selecting the rows to fit (e.g. "
                                                    "\"batch == 'x1'\"; comparisons joined by "
                                                    "and/or/not, see svrqp.query); the other rows "
                                                    "are assessed. Default: all rows."),
    C: float = typer.Option(1.0, "--C", help="svr/lssvr: the regularisation weight C."),
    epsilon: float = typer.Option(0.1, "--epsilon", help="svr: half-width of the ε-tube, in target "
                                                         "units."),
    gamma: str = typer.Option("scale", "--gamma", help="svr/lssvr: RBF gamma in exp(-γ‖x−x'‖²) "
                              "(S0's g = 1/σ²; S4's σ gives 1/(2σ²)), or 'scale'/'auto'."),
    degree: int = typer.Option(5, "--degree", help="poly: polynomial degree (S2: 5)."),
    forgetting: float = typer.Option(1.0, "--forgetting",
                                     help="rls: forgetting factor λ in (0, 1]."),
    solver: str = typer.Option("auto", "--solver", help=SOLVER_HELP),
    standardize: bool = typer.Option(False, "--standardize", help="svr/lssvr: standardise the "
                                                                  "inputs before the kernel."),
    coverage: float = typer.Option(None, "--coverage", help=COVERAGE_HELP),
    group: str = typer.Option(None, "--group", help=GROUP_HELP),
    interval: str = typer.Option("absolute", "--interval", help=INTERVAL_HELP),
) -> None:
    """Fit a model on the --train rows; print its
    coefficients and the residuals on every row set."""
    model = model.value
    # Imported when the command runs: `svrqp fit --help` loads no scikit-learn.
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
        interval_table,
    )
    from svrqp.compensate import online_compensation
    from svrqp.export.guarded import sections
    from svrqp.guard import Guarded

    table = read_table(data)
    columns = split_columns(features, table, "--features", numeric=True)
    if not columns:
        raise ProblemError("--features: give at least one column")
    split_columns(target, table, "--target", numeric=True)
    if standardize and model not in ("svr", "lssvr"):
        raise ProblemError("--standardize applies to svr and lssvr only")
    estimator = make_estimator(model, C=C, epsilon=epsilon, gamma=parse_gamma(gamma), degree=degree,
                               forgetting=forgetting, solver=solver)
    fitted = guarded_or_plain(estimator, coverage, group, interval, standardize=standardize)
    groups = group_labels(table, group)
    mask = select_train_rows(table, train)
    X, y = table[columns], table[target]
    X_train, y_train, X_other, y_other = X[mask], y[mask], X[~mask], y[~mask]
    console = Console()
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                  console=Console(stderr=True), transient=True) as progress:
        progress.add_task(f"fitting {model} on {len(y_train)} rows", total=None)
        fit_guarded(fitted, X_train, y_train, None if groups is None else groups[mask])
    typer.echo(f"{model}: {target} ~ {', '.join(columns)}; {len(y_train)} train rows, "
               f"{len(y_other)} other rows")
    guarded = fitted if isinstance(fitted, Guarded) else None
    fitted = fitted.estimator_ if guarded is not None else fitted
    _print_model(console, fitted, target)
    rows = [("train", y_train.to_numpy(dtype=float) - fitted.predict(X_train))]
    if len(y_other):
        rows.append(("other", y_other.to_numpy(dtype=float) - fitted.predict(X_other)))
        if model == "rls":
            online = online_compensation(fitted, X_other, y_other)
            rows.append(("online", online.run.residual_um))
    console.print(_metrics_table(rows, split_unit(target)[1]))
    if guarded is not None:
        typer.echo(describe_interval(sections(guarded)["interval"]))
        row_sets = [("train", X_train,
                     y_train)] + ([("other", X_other, y_other)] if len(y_other) else [])
        console.print(interval_table(guarded, row_sets, split_unit(target)[1]))


def register(app: typer.Typer) -> None:
    """Add ``svrqp fit`` to ``app``."""
    app.command("fit")(fit_command)
