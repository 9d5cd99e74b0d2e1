"""``svrqp verify FILE``: check an exported model from the file alone (schema, hash, probes)."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    """Add ``svrqp verify`` to ``app``."""

    @app.command("verify")
    def verify_command(
        file: Path = typer.Argument(..., help="An exported model, svrqp.model/1 JSON."),
    ) -> None:
        """Validate the schema, recompute the content hash and
        re-evaluate the probe points; exit 1 on failure."""
        from svrqp.export import (
            verify,  # imported when the command runs: `svrqp verify --help` stays quick
        )

        if not file.is_file():
            raise FileNotFoundError(f"model file not found: {file}")
        report = verify(file)
        for check in report.checks:
            typer.echo(f"{'OK  ' if check.ok else 'FAIL'} {check.name:<7} {check.detail}")
        deviation = "n/a" if report.max_deviation is None else f"{report.max_deviation:.3g}"
        typer.echo(f"{'OK' if report.ok else 'FAIL'} {file} (largest probe deviation {deviation})")
        if not report.ok:
            # SystemExit, not typer.Exit: click returns (drops)
            # typer.Exit's code in standalone_mode=False.
            raise SystemExit(1)
