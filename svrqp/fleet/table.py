"""The fleet table: one row per record, read from its ``svrqp.gap/2`` document, and the long table
of each record's per-candidate transfer tests that the pooled evidence combines.

Row columns: ``name``, ``path``, ``status`` (``ok``, ``resumed`` — an earlier run's output with
the same input checksum and settings — or ``failed``), ``reason`` (why a record failed),
``n_rows``, ``n_real``, ``gap_detected``, ``train_rmse_um``/``real_rmse_um`` and ``gap_ratio``
(the gap's size), ``verdict_column``, ``verdict_transform`` (its form), ``shrink`` with
``shrink_low``/``shrink_high`` (its 95 % interval), ``extrapolated`` (model inputs and candidates
used outside their train range, comma-separated), ``runtime_s`` (reading, checksum, diagnosis and
writing, on the worker) and ``sha256`` of the input file. The RMSE columns carry the unit of the
target, named μm here as for the simulated fleets and the embedded data.

The test table has one row per record and candidate: ``name``, ``column``, ``transform`` (the
column's best-transferring form), ``gain`` (its transfer gain), ``tested`` and ``p_raw`` (the
record's own transfer test's p-value before its false-discovery control; 1 when the record did
not test the column, below the effect floor), and ``p_pool``: the transfer test's p-value for
every candidate, the record's own where it tested the column, else the same test drawn for the
fleet on its own stream (:mod:`svrqp.gap.transfer.pooling`); the pooled evidence combines it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

ROW_COLUMNS = ("name", "path", "status", "reason", "n_rows", "n_real", "gap_detected",
               "train_rmse_um", "real_rmse_um", "gap_ratio", "verdict_column",
               "verdict_transform", "shrink", "shrink_low", "shrink_high", "extrapolated",
               "runtime_s", "sha256")
TEST_COLUMNS = ("name", "column", "transform", "gain", "tested", "p_raw", "p_pool")


def row_of(name: str, path: Path, document: dict[str, Any], *, status: str, runtime_s: float,
           sha256: str) -> dict[str, Any]:
    """The fleet-table row of a record from its gap document."""
    verdict = document["verdict"]
    interval = verdict.get("shrink_ci") or (None, None)
    extrapolated = [u["column"] for u in document["inputs"] if u.get("extrapolated")]
    return {
        "name": name, "path": str(path), "status": status, "reason": "",
        "n_rows": document["n_rows"], "n_real": document["n_real"],
        "gap_detected": document["gap"]["detected"],
        "train_rmse_um": document["gap"]["train_rmse"],
        "real_rmse_um": document["gap"]["real_rmse"], "gap_ratio": document["gap"]["ratio"],
        "verdict_column": verdict["column"] or "", "verdict_transform": verdict["transform"] or "",
        "shrink": verdict.get("shrink"), "shrink_low": interval[0], "shrink_high": interval[1],
        "extrapolated": ",".join(extrapolated), "runtime_s": runtime_s, "sha256": sha256,
    }


def failed_row(name: str, path: Path, reason: str, runtime_s: float) -> dict[str, Any]:
    """The row of a record whose diagnosis failed, with the reason in one line."""
    row: dict[str, Any] = dict.fromkeys(ROW_COLUMNS)
    row.update(name=name, path=str(path), status="failed", reason=" ".join(reason.split()),
               runtime_s=runtime_s, verdict_column="", verdict_transform="", extrapolated="",
               sha256="")
    return row


def tests_of(name: str, document: dict[str, Any],
             pool: dict[str, float] | None = None) -> list[dict[str, Any]]:
    """The per-candidate transfer tests of a record (its ``causes``), one row per column, with
    ``pool`` (column -> p-value, :mod:`svrqp.gap.transfer.pooling`) as ``p_pool``; a column it
    lacks counts as ``p_raw``."""
    rows, seen = [], set()
    for cause in document["causes"]:
        if cause["column"] in seen or cause.get("region") is not None:
            continue  # one test per column: its best global form (local windows stay apart)
        seen.add(cause["column"])
        tested = bool(cause["tested"]) and cause["p_raw"] is not None
        p_raw = float(cause["p_raw"]) if tested else 1.0
        rows.append({"name": name, "column": cause["column"], "transform": cause["transform"],
                     "gain": cause["gain"], "tested": tested, "p_raw": p_raw,
                     "p_pool": float((pool or {}).get(cause["column"], p_raw))})
    return rows


def frame(rows: list[dict[str, Any]], columns: tuple[str, ...]):
    """The rows as a DataFrame with ``columns`` in order, sorted by name."""
    import pandas as pd

    table = pd.DataFrame(rows, columns=list(columns))
    return table.sort_values("name", kind="stable").reset_index(drop=True)


def write_table(table, stem: Path, *, force: bool = False) -> list[Path]:
    """Write ``table`` as ``STEM.csv``, and ``STEM.parquet`` when the parquet extra is here."""
    from svrqp import output
    from svrqp.extras import has_extra

    written = []
    with output.replacing(stem.with_suffix(".csv"), force=force) as tmp:
        table.to_csv(tmp, index=False)
    written.append(stem.with_suffix(".csv"))
    if has_extra("parquet"):
        with output.replacing(stem.with_suffix(".parquet"), force=force) as tmp:
            table.to_parquet(tmp, index=False)
        written.append(stem.with_suffix(".parquet"))
    return written
