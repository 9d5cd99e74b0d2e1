"""A whole fleet in one call: check the output folder, run every record, write the fleet's files.

The folder ``out`` receives ``records/NAME.json`` (each record's ``svrqp.gap/2`` document, as
``svrqp gap --json`` writes it) with its stamp ``records/NAME.fleet.json``; ``fleet.csv`` (and
``fleet.parquet`` with the parquet extra), the fleet table of :mod:`svrqp.fleet.table`;
``tests.csv``, every record's per-candidate transfer tests; ``pooled.csv``, the pooled evidence
of :mod:`svrqp.fleet.pooled`; and ``fleet.html``, the page of :mod:`svrqp.fleet.report`.

A folder that already holds a fleet is refused unless the run resumes it (``resume``: records
whose input and settings are unchanged are taken as they are, the others are diagnosed again) or
replaces it (``force``: every record is diagnosed again).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from svrqp.exceptions import ProblemError
from svrqp.fleet.manifest import Record
from svrqp.fleet.pooled import PooledVerdict, pool
from svrqp.fleet.record import options_for
from svrqp.fleet.run import RECORDS, Execution, results
from svrqp.fleet.table import ROW_COLUMNS, TEST_COLUMNS, frame, write_table

TABLE, TESTS, POOLED, PAGE = "fleet", "tests", "pooled", "fleet.html"


@dataclass(frozen=True)
class FleetResult:
    """What a fleet run gives: the fleet table, the per-record tests, the pooled verdict."""

    table: pd.DataFrame
    tests: pd.DataFrame
    pooled: PooledVerdict
    written: list[Path]

    @property
    def failed(self) -> pd.DataFrame:
        """The rows of the records that failed, with their reasons."""
        return self.table[self.table["status"] == "failed"]


def check_folder(out: Path, *, resume: bool, force: bool) -> None:
    """Refuse, before any work, a folder that cannot be written or that holds a fleet already."""
    if out.exists() and not out.is_dir():
        raise ProblemError(f"--out {out}: exists and is not a folder")
    try:
        (out / RECORDS).mkdir(parents=True, exist_ok=True)
        handle, name = tempfile.mkstemp(prefix=".svrqp-write-test.", dir=out / RECORDS)
        os.close(handle)
        os.unlink(name)
    except OSError as err:
        raise ProblemError(f"--out {out}: the folder cannot be written ({err.strerror})") from None
    if (out / f"{TABLE}.csv").exists() and not (resume or force):
        raise FileExistsError(f"--out {out} holds a fleet already: pass --resume to keep the "
                              f"records that did not change, or --force to diagnose all again")


def run_fleet(records: list[Record], defaults: dict[str, Any], out: str | Path, *,
              execution: Execution | None = None, resume: bool = False, force: bool = False,
              progress: Callable[[int, int], None] | None = None) -> FleetResult:
    """Diagnose every record and write the fleet's files into ``out``.

    Parameters
    ----------
    records
        From :func:`svrqp.fleet.manifest.read_records`.
    defaults
        The options of every record, named as the fields of
        :class:`~svrqp.fleet.record.GapOptions` (a record's manifest row overrides some of them).
    out
        The output folder (created if needed; checked writable before any work).
    execution
        Serial (the default), a local Dask cluster of ``workers`` processes, or an existing
        ``scheduler``.
    resume, force
        Keep unchanged records of an earlier run in ``out``; or diagnose all of them again.
    progress
        Called with (records done, records in all) after each record.
    """
    out, execution = Path(out), execution or Execution()
    jobs = [(r, options_for(defaults, r.overrides, f"record {r.name!r}")) for r in records]
    check_folder(out, resume=resume, force=force)
    rows, tests = [], []
    for done, outcome in enumerate(results(jobs, out, execution, resume=resume), 1):
        rows.append(outcome.row)
        tests.extend(outcome.tests)
        if progress is not None:
            progress(done, len(records))
    table, test_table = frame(rows, ROW_COLUMNS), frame(tests, TEST_COLUMNS)
    pooled = pool(test_table)
    written = write_outputs(out, table, test_table, pooled)
    return FleetResult(table, test_table, pooled, written)


def write_outputs(out: Path, table: pd.DataFrame, tests: pd.DataFrame,
                  pooled: PooledVerdict) -> list[Path]:
    """Write the fleet table, the tests, the pooled table and the page (each whole or none)."""
    from svrqp import output
    from svrqp.fleet.report import fleet_html

    written = write_table(table, out / TABLE, force=True)
    written += write_table(tests, out / TESTS, force=True)
    written += write_table(pooled.table, out / POOLED, force=True)
    written.append(output.write_text(out / PAGE, fleet_html(table, pooled), force=True))
    return written
