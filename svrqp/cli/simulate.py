"""``svrqp simulate`` and ``svrqp plot``: generate machine data, and draw it as S0 does.

``svrqp simulate thermal|axis|gantry --config FILE.toml --out data.csv`` runs one simulator of
:mod:`svrqp.machine`. The TOML file sets fields of the simulator's config dataclass
(:class:`~svrqp.machine.thermal.ThermalConfig`, :class:`~svrqp.machine.geometry.AxisConfig`,
:class:`~svrqp.machine.contour.GantryConfig`); nested parts are tables (``[ambient]``) and
lists of parts are arrays of tables (``[[cycle]]``, ``[[sensors]]``, ``[[lines]]``). Any field
left out keeps its default, so an effect is withheld with a single line such as
``ambient_drift = 0.0``.

``svrqp simulate thermal --fleet N --out FOLDER`` draws N machines of one type instead
(:mod:`svrqp.machine.fleet`): one CSV each, with ``manifest.csv`` for ``svrqp fleet`` and
``truth.csv``.

``svrqp plot DATA.csv --out fig.png`` draws the temperatures and the error over time (or
position), one column of panels per batch, with the effect contributions dashed when the
table has them.
"""

from __future__ import annotations

from collections.abc import Callable
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.console import Console
from rich.progress import (
    BarColumn,
    Progress,
    TaskProgressColumn,
    TextColumn,
    TimeElapsedColumn,
)

from svrqp import output
from svrqp.cli._common import read_table, split_columns
from svrqp.exceptions import ProblemError
from svrqp.units import axis_label

if TYPE_CHECKING:
    import pandas as pd

ORDER_COLUMNS = ("time_min", "time_s", "x_mm")
TARGET_COLUMNS = ("error_um", "deviation_um")


class Kind(str, Enum):
    """The simulators ``svrqp simulate`` can run."""

    thermal = "thermal"
    axis = "axis"
    gantry = "gantry"


class NineLineSet(str, Enum):
    """Measurement sets of the nine-line method."""

    original = "original"
    improved = "improved"


def run_simulation(
    kind: Kind,
    config_path: Path | None,
    seed: int,
    nine_line: NineLineSet | None = None,
    progress: Callable[[float], None] | None = None,
) -> pd.DataFrame:
    """Build the config of ``kind`` (defaults, or ``config_path``) and run the simulator."""
    # Imported when a simulation runs: `svrqp simulate --help` loads no simulator.
    from svrqp.machine._config import load_toml
    from svrqp.machine.contour import GantryConfig, simulate_gantry
    from svrqp.machine.geometry import AxisConfig, measure_nine_line, simulate_axis
    from svrqp.machine.thermal import ThermalConfig, simulate_thermal

    if nine_line is not None and kind is not Kind.axis:
        raise ProblemError("--nine-line applies to the axis simulator only")
    if kind is Kind.thermal:
        config = ThermalConfig() if config_path is None else load_toml(ThermalConfig, config_path)
        return simulate_thermal(config, seed=seed, progress=progress)
    if kind is Kind.axis:
        config = AxisConfig() if config_path is None else load_toml(AxisConfig, config_path)
        if nine_line is not None:
            return measure_nine_line(config, nine_line.value, seed=seed)
        return simulate_axis(config, seed=seed)
    config = GantryConfig() if config_path is None else load_toml(GantryConfig, config_path)
    return simulate_gantry(config, seed=seed)


def plot_table(
    table: pd.DataFrame,
    target: str | None = None,
    temperatures: list[str] | None = None,
    group: str | None = None,
):
    """Figure of temperatures (top) and error with its effects (bottom) against time or position.

    Parameters
    ----------
    table
        A simulator output, an embedded dataset, or measured data with unit-suffixed columns.
    target
        The error column; default the first of ``error_um``, ``deviation_um`` present.
    temperatures
        Temperature columns to draw; default every ``*_C`` column except ``true_*``.
    group
        Column whose values get one column of panels each (default ``batch`` when present).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    matplotlib.use("Agg")  # files only, never a display
    import matplotlib.pyplot as plt

    order = next((c for c in ORDER_COLUMNS if c in table.columns), None)
    if order is None:
        raise ProblemError(f"plot: the table needs an order column, one of {list(ORDER_COLUMNS)}")
    if target is None:
        target = next((c for c in TARGET_COLUMNS if c in table.columns), None)
        if target is None:
            raise ProblemError(f"plot: no error column {list(TARGET_COLUMNS)}; name one with "
                               f"--target")
    if temperatures is None:
        temperatures = [c for c in table.columns if c.endswith("_C") and not c.startswith("true_")]
    if group is None and "batch" in table.columns:
        group = "batch"
    effects = [c for c in table.columns if c.startswith("effect_")]
    groups = list(table.groupby(group, sort=True)) if group else [(None, table)]

    rows = 2 if temperatures else 1
    fig, axes = plt.subplots(rows, len(groups), figsize=(5.0 * len(groups), 3.2 * rows),
                             squeeze=False, sharex="col", sharey="row")
    for j, (name, part) in enumerate(groups):
        if temperatures:
            ax = axes[0, j]
            for column in temperatures:
                ax.plot(part[order], part[column], lw=1.0, label=column)
            ax.set_ylabel("temperature (°C)")
            ax.set_title(f"{group} = {name}" if group else "")
        ax = axes[-1, j]
        ax.plot(part[order], part[target], color="k", lw=1.3, label=target)
        for column in effects:
            ax.plot(part[order], part[column], ls="--", lw=0.9, label=column)
        ax.set_xlabel(axis_label(order))
        ax.set_ylabel(axis_label(target))
        ax.axhline(0.0, color="0.6", lw=0.6)
    if temperatures:
        axes[0, -1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[-1, -1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    return fig


def _simulate_fleet(kind: Kind, out: Path, n: int, snr: float, seed: int, force: bool,
                    refused: dict[str, object]) -> None:
    """``simulate thermal --fleet N --out FOLDER`` (:func:`svrqp.machine.fleet.write_fleet`)."""
    from svrqp.machine.fleet import FleetDesign, write_fleet

    if kind is not Kind.thermal:
        raise ProblemError("--fleet draws machining centres: use it with the thermal simulator")
    given = [name for name, value in refused.items() if value is not None]
    if given:
        raise ProblemError(f"--fleet draws its own machines: {', '.join(given)} does not apply")
    if out.exists() and not out.is_dir():
        raise ProblemError(f"--out {out}: with --fleet, give a folder")
    design = FleetDesign(n=n, seed=seed, snr={"nut": snr, "headstock": snr})
    with Progress(TextColumn("machines"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
                  console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task("machines", total=n)
        manifest = write_fleet(out, design, force=force,
                               progress=lambda done: bar.update(task, completed=done))
    typer.echo(f"wrote {n} machine records, {manifest} and {out / 'truth.csv'}")


def register(app: typer.Typer) -> None:
    """Add ``svrqp simulate`` and ``svrqp plot`` to ``app``."""

    @app.command("simulate")
    def simulate_command(
        kind: Kind = typer.Argument(..., help="Simulator: thermal (machining-centre thermal "
                                              "drift), "
                                    "axis (linear-axis geometric errors), gantry (2X/Y contour)."),
        out: Path = typer.Option(..., "--out", help="CSV file to write (with --fleet: a folder)."),
        config: Path = typer.Option(None, "--config", help="TOML file setting fields of the "
                                    "simulator's config (e.g. 'ambient_drift = 0.0'); default: "
                                    "the built-in defaults."),
        seed: int = typer.Option(0, "--seed", help="Seed of the noise generator "
                                 "(same seed, same data)."),
        nine_line: NineLineSet = typer.Option(None, "--nine-line", help="axis only: write the "
                                              "interferometer readings of this nine-line set "
                                              "instead of the tool-point error table."),
        force: bool = typer.Option(False, "--force", help="Replace --out if it exists (a symbolic "
                                                          "link is replaced, never written "
                                                          "through)."),
        fleet: int = typer.Option(None, "--fleet", help="thermal only: draw this many machines of "
                                  "one type (svrqp.machine.fleet) into the folder --out: one CSV "
                                  "each, manifest.csv (ready for svrqp fleet) and truth.csv."),
        fleet_snr: float = typer.Option(2.0, "--fleet-snr", help="With --fleet: strength of the "
                                        "withheld effects (their within-run spread over the "
                                        "probe noise's)."),
    ) -> None:
        """Simulate a machine with switchable physical effects and write the table as CSV."""
        if fleet is not None:
            _simulate_fleet(kind, out, fleet, fleet_snr, seed, force,
                            refused={"--config": config, "--nine-line": nine_line})
            return
        output.check_target(out, force=force)
        with Progress(TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(),
                      TimeElapsedColumn(), console=Console(stderr=True), transient=True) as bar:
            task = bar.add_task(f"simulating {kind.value}", total=1.0)
            table = run_simulation(kind, config, seed, nine_line,
                                   progress=lambda done: bar.update(task, completed=done))
            bar.update(task, completed=1.0)
        with output.replacing(out, force=force) as temporary:
            table.to_csv(temporary, index=False)
        effects = [c.removeprefix("effect_").removesuffix("_um")
                   for c in table if c.startswith("effect_")]
        typer.echo(f"wrote {out}: {len(table)} rows, {table.shape[1]} columns"
                   + (f"; effects: {', '.join(effects)}" if effects else ""))

    @app.command("plot")
    def plot_command(
        data: Path = typer.Argument(..., help="CSV or Parquet table (simulator output, a dataset, "
                                    "or measurements) with time_min, time_s or x_mm."),
        out: Path = typer.Option(..., "--out", help="Image file to write (PNG, PDF or SVG)."),
        target: str = typer.Option(None, "--target", help="Error column (default error_um or "
                                   "deviation_um)."),
        temperatures: str = typer.Option(None, "--temperatures", help="Comma-separated temperature "
                                         "columns (default every *_C column)."),
        group: str = typer.Option(None, "--group", help="Column with one panel column per value "
                                  "(default batch when present)."),
        force: bool = typer.Option(False, "--force", help="Replace --out if it exists (a symbolic "
                                                          "link is replaced, never written "
                                                          "through)."),
    ) -> None:
        """Plot temperatures and error over time, as the figures of S0 do."""
        output.check_target(out, force=force)
        table = read_table(data)
        if target is not None:
            split_columns(target, table, "--target", numeric=True)
        if group is not None:
            split_columns(group, table, "--group")
        chosen = split_columns(temperatures, table, "--temperatures",
                               numeric=True) if temperatures else None
        figure = plot_table(table, target=target, temperatures=chosen, group=group)
        with output.replacing(out, force=force) as temporary:
            figure.savefig(temporary, dpi=120, bbox_inches="tight")
        import matplotlib.pyplot as plt

        plt.close(figure)
        typer.echo(f"wrote {out}")
