"""Helpers shared by the subcommands: reading tables, splitting column lists."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from svrqp.exceptions import ProblemError


def read_table(path: str | Path) -> pd.DataFrame:
    """Read a CSV or Parquet file into a DataFrame, with a clear error when it is missing."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"input file not found: {path}")
    if path.suffix.lower() in {".parquet", ".pq"}:
        return pd.read_parquet(path)
    return pd.read_csv(path)


def split_columns(text: str | None, table: pd.DataFrame, option: str) -> list[str]:
    """Split ``"a,b,c"`` into column names and check that each is in ``table``."""
    if text is None or not text.strip():
        return []
    names = [name.strip() for name in text.split(",") if name.strip()]
    missing = [name for name in names if name not in table.columns]
    if missing:
        raise ProblemError(
            f"{option}: unknown column(s) {missing}; available: {list(table.columns)}"
        )
    return names
