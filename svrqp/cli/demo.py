"""``svrqp demo``: the papers' main results on the embedded simulated data, in about two minutes.

``--quick`` (about a quarter of a minute) shrinks S0's grid and S1's genetic algorithm.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table


def _s0_table(s0: dict[str, Any]) -> Table:
    table = Table(title=f"S0 — RMS of the residuals (μm), models fitted on x1 ({s0['dataset']}: "
                        f"temperature rises)",
                  caption=s0["sentence"])
    for column in ("model", "batch", "RMS (μm)", "S0 published RMS (μm)", "std, mean removed (μm)"):
        table.add_column(column, justify="left" if column in ("model", "batch") else "right")
    for row in s0["table"]:
        table.add_row(row["model"], row["batch"], f"{row['rms_um']:.3f}",
                      "—" if row["paper_rms_um"] is None else f"{row['paper_rms_um']:.3f}",
                      f"{row['std_um']:.3f}")
    return table


def _reproduction_table(rows: list[dict[str, Any]]) -> Table:
    from svrqp.demo.vocabulary import COLUMNS, cells, rule_text

    table = Table(title="Reproduction: the papers' numbers and ours (reasons in report.html)",
                  caption=rule_text())
    for column in COLUMNS:
        table.add_column(column, justify="right" if column in ("paper", "ours", "tolerance")
                         else "left")
    for row in rows:
        table.add_row(*cells(row))
    return table


def print_summary(console: Console, results: dict[str, Any], out: Path) -> None:
    """The demo's results as the terminal shows them."""
    from svrqp.demo.report import SIMULATED_NOTE, verdict_label

    console.print(f"[bold]{SIMULATED_NOTE}[/bold]")
    console.print(_reproduction_table(results["reproduction"]))
    console.print(_s0_table(results["s0"]))
    for note in results["s0"]["extrapolation"]:
        console.print(note)
    best = results["s0"]["cv"]["best_params"]
    console.print(f"ε-SVR: 5-fold CV chose C = {best['C']:g}, γ = g = {best['gamma']:g} (ε = "
                  f"{results['s0']['epsilon_um']} μm), {results['s0']['n_support']} support "
                  f"vectors (S0: 56).")
    s4 = results["s4"]
    console.print(f"S4 — straightness (peak-to-valley from the LS line) of runs {s4['test_runs']}, "
                  f"unseen by the model fitted on run {s4['train_run']}: {s4['before_um']:.2f} → "
                  f"{s4['after_um']:.2f} μm after LS-SVR compensation with the dead band: "
                  f"{s4['improvement_percent']:.0f} % better (S4: {s4['paper']['before_um']:g} → "
                  f"{s4['paper']['after_um']:g} μm, {s4['paper']['improvement_percent']:g} %).")
    s2 = results["s2"]
    console.print("S2 — nine-line δx identification error: improved "
                  f"{s2['max_error_improved']['delta_x_um']:.3f} μm, original "
                  f"{s2['max_error_original']['delta_x_um']:.3f} μm (max over 11 positions); δx "
                  f"model MSE SVR {s2['mse_um2']['svr_fit']:.4g} vs 5th-order LSM "
                  f"{s2['mse_um2']['lsm_fit']:.4g} μm² (fit), {s2['mse_um2']['svr_loo']:.4g} vs "
                  f"{s2['mse_um2']['lsm_loo']:.4g} μm² (leave-one-out); S2: "
                  f"{s2['paper']['mse_svr']} vs {s2['paper']['mse_lsm']}.")
    console.print(s2["variant_note"])
    s1 = results["s1"]
    console.print(f"S1 — GA population {s1['genetic']['population']} × "
                  f"{s1['genetic']['generations']} generations"
                  f"{' (quick run; S1: 100 × 50)' if s1['quick'] else ''}: C = "
                  f"{s1['best_params']['C']:.4g}, ε = {s1['best_params']['epsilon']:.3g} μm; Σ|r| "
                  f"on test {s1['sum_abs_um']['ga']:.3g} (GA) vs {s1['sum_abs_um']['untuned']:.3g} "
                  f"μm (untuned); S1: 25 vs 28. {s1['edge_text']}")
    verify = results["export"]["verify"]
    console.print(f"Export — {', '.join(results['export']['files'])}: verify "
                  f"{'OK' if verify['ok'] else 'FAIL'} (largest probe deviation "
                  f"{verify['max_deviation']:.3g}).")
    console.print("Gap (summer MLR on absolute temperatures, autumn x3) — verdict: "
                  f"{verdict_label(results['gap']['verdict'])}. {results['gap']['summary']}")
    console.print(f"Everything is in {out}/ — open {out / 'report.html'} "
                  f"({results['runtime_s']:.0f} s).")


def register(app: typer.Typer) -> None:
    """Add ``svrqp demo`` to ``app``."""

    @app.command("demo")
    def demo_command(
        out: Path = typer.Option(Path("demo-output"), "--out", "-o", help="Output directory, "
                                                                          "created fresh."),
        quick: bool = typer.Option(False, "--quick", help="Smaller CV grid for S0 and GA for S1 "
                                                          "(a quick look, and the tests)."),
        force: bool = typer.Option(False, "--force", help="Write into an existing non-empty --out, "
                                                          "replacing the demo's own files."),
        jobs: int = typer.Option(None, "--jobs", min=1, help="Parallel workers of the S0 "
                                                             "cross-validation "
                                                              "(default 2; 1 with --quick)."),
    ) -> None:
        """Reproduce S0–S4 on the embedded simulated
        data, export and verify S0's ε-SVR, diagnose the gap."""
        from svrqp.demo import (
            run_demo,  # imported when the command runs: `svrqp demo --help` stays quick
        )
        from svrqp.demo.run import REQUIRED_EXTRA, require

        # before the progress bar: a missing extra is one line, nothing else
        require(*REQUIRED_EXTRA)
        console = Console()
        with Progress(TextColumn("{task.description}"), BarColumn(),
                      TextColumn("{task.percentage:>3.0f}%"),
                      TimeElapsedColumn(), console=Console(stderr=True),
                      transient=True) as progress:
            task = progress.add_task("starting", total=1.0)
            results = run_demo(out, quick=quick, force=force, n_jobs=jobs,
                               progress=lambda step,
                               done: progress.update(task, description=step, completed=done))
        print_summary(console, results, out)
