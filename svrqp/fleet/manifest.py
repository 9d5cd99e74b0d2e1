"""The records of a fleet: a manifest (CSV or TOML) or a glob, checked before any work.

A CSV manifest has one row per record: ``path`` (relative to the manifest's folder, or
absolute), an optional ``name`` (default: the file's stem) and optional columns overriding the
fleet's options for that record (:data:`svrqp.fleet.record.PER_RECORD`: ``target``, ``train``,
``features``, ``model``, ``prediction``, ``candidates``, ``order``, ``group``); an empty cell
keeps the fleet's option. A TOML manifest says the same as an array of tables::

    [[record]]
    path = "m01.csv"
    train = "run < 3"

A glob (``"records/*.csv"``) names one record per file, with the fleet's options. Every
record's file must exist and every name must be unique: a manifest that breaks either is refused
whole, in one line, before anything runs.
"""

from __future__ import annotations

import glob as globbing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from svrqp.exceptions import ProblemError
from svrqp.fleet.record import PER_RECORD

MANIFEST_SUFFIXES = (".csv", ".toml")


@dataclass(frozen=True)
class Record:
    """One record of a fleet: its name (the stem of its output files), its file, its overrides."""

    name: str
    path: Path
    overrides: dict[str, Any] = field(default_factory=dict)


def read_records(source: str | Path) -> list[Record]:
    """The records named by a manifest file (``.csv`` or ``.toml``) or by a glob pattern.

    Raises
    ------
    ProblemError
        No record, a record whose file is missing, two records of one name, an unknown column.
    """
    text = str(source)
    path = Path(text)
    if path.suffix.lower() in MANIFEST_SUFFIXES and path.is_file():
        rows = _toml_rows(path) if path.suffix.lower() == ".toml" else _csv_rows(path)
        records = [_record(row, path.parent, f"{path.name} row {i + 1}")
                   for i, row in enumerate(rows)]
        where = path.name
    elif any(ch in text for ch in "*?["):
        records = [Record(Path(p).stem, Path(p)) for p in sorted(globbing.glob(text))]
        where = f"the pattern {text!r}"
    elif path.suffix.lower() in MANIFEST_SUFFIXES:
        raise ProblemError(f"manifest not found: {path}")
    else:
        raise ProblemError(f"{text}: give a manifest (.csv or .toml) or a glob pattern of record "
                           f"files (e.g. 'records/*.csv')")
    if not records:
        raise ProblemError(f"{where} names no record")
    _check(records, where)
    return records


def _csv_rows(path: Path) -> list[dict[str, Any]]:
    import pandas as pd

    table = pd.read_csv(path, dtype=str, keep_default_na=False)
    if "path" not in table.columns:
        raise ProblemError(f"{path.name}: a manifest needs a 'path' column (give record files "
                           f"themselves as a glob: 'folder/*.csv')")
    return [{k: (v.strip() or None) for k, v in row.items()} for row in table.to_dict("records")]


def _toml_rows(path: Path) -> list[dict[str, Any]]:
    import tomllib

    with path.open("rb") as handle:
        try:
            document = tomllib.load(handle)
        except tomllib.TOMLDecodeError as err:
            raise ProblemError(f"{path.name}: not valid TOML ({err})") from None
    rows = document.get("record", [])
    if not isinstance(rows, list) or not all(isinstance(row, dict) for row in rows):
        raise ProblemError(f"{path.name}: give the records as [[record]] tables")
    return rows


def _record(row: dict[str, Any], folder: Path, where: str) -> Record:
    row = dict(row)
    unknown = sorted(set(row) - {"name", "path", *PER_RECORD})
    if unknown:
        raise ProblemError(f"{where}: unknown column(s) {unknown}; a record has name, path and "
                           f"{', '.join(PER_RECORD)}")
    if not row.get("path"):
        raise ProblemError(f"{where}: no path")
    path = Path(str(row.pop("path")))
    path = path if path.is_absolute() else folder / path
    name = str(row.pop("name", None) or path.stem)
    return Record(name, path, {k: v for k, v in row.items() if v is not None})


def _check(records: list[Record], where: str) -> None:
    """Refuse a missing file or a repeated name (outputs would overwrite each other)."""
    missing = [str(r.path) for r in records if not r.path.is_file()]
    if missing:
        more = f" and {len(missing) - 1} more" if len(missing) > 1 else ""
        raise ProblemError(f"{where}: record file not found: {missing[0]}{more}")
    seen: dict[str, Path] = {}
    for record in records:
        if record.name in seen:
            raise ProblemError(f"{where}: two records named {record.name!r} ({seen[record.name]} "
                               f"and {record.path}); give each a unique name")
        bad = set(record.name) & set('/\\:*?"<>|')
        if bad or record.name in {".", ".."}:
            raise ProblemError(f"{where}: record name {record.name!r} cannot name a file")
        seen[record.name] = record.path
