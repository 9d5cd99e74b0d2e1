"""Load and verify an exported model from the file alone.

:func:`verify` runs three checks and reports each:

1. **schema** — strict JSON parsing (no code is ever executed: no pickle, no ``eval``) and the
   ``svrqp.model/1`` JSON Schema with its shape checks (:func:`svrqp.export.schema.validate_document`);
2. **hash** — ``content_sha256`` recomputed from the canonical content (:mod:`svrqp.export.canonical`);
3. **probes** — the stored probe inputs re-evaluated from the file's numbers
   (:func:`svrqp.export.evaluate.predict`); the largest deviation from the stored predictions must
   be within the stored tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from svrqp.exceptions import ProblemError
from svrqp.export import canonical, evaluate
from svrqp.export.schema import validate_document


@dataclass(frozen=True)
class Check:
    """One verification step: its name, whether it passed, and what was found."""

    name: str
    ok: bool
    detail: str


@dataclass
class VerifyReport:
    """The outcome of :func:`verify`."""

    path: str
    checks: list[Check] = field(default_factory=list)
    max_deviation: float | None = None
    tolerance: float | None = None

    @property
    def ok(self) -> bool:
        """True when all three checks ran and passed."""
        return len(self.checks) == 3 and all(check.ok for check in self.checks)


def read_document(path: str | Path) -> dict[str, Any]:
    """Parse a model file strictly and validate it; errors name the file and the field.

    Raises
    ------
    ProblemError
        When the file is not JSON, or not a valid ``svrqp.model/1`` document.
    FileNotFoundError
        When the file does not exist.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"model file not found: {path}")
    try:
        document = canonical.parse_strict(path.read_text(encoding="utf-8"))
        validate_document(document)
    except (ProblemError, UnicodeDecodeError) as err:
        raise ProblemError(f"{path}: {err}") from None
    return document


def probe_deviation(document: dict[str, Any]) -> float:
    """Largest |stored − re-evaluated| prediction over the probe points."""
    probes = document["probes"]
    recomputed = evaluate.predict(document, np.asarray(probes["X"], dtype=float))
    return float(np.max(np.abs(recomputed - np.asarray(probes["prediction"]))))


def verify(path: str | Path) -> VerifyReport:
    """Verify the model file at ``path``: schema, content hash, probe predictions."""
    report = VerifyReport(str(path))
    try:
        document = read_document(path)
    except ProblemError as err:
        report.checks.append(Check("schema", False, str(err)))
        return report
    report.checks.append(Check("schema", True, f"valid {document['schema']} ({document['kind']})"))
    stored = document["content_sha256"]
    recomputed = canonical.content_sha256(document)
    report.checks.append(Check("hash", stored == recomputed,
                               f"content_sha256 {stored}" if stored == recomputed
                               else f"content_sha256 stored {stored}, recomputed {recomputed}"))
    report.max_deviation = probe_deviation(document)
    report.tolerance = document["probes"]["tolerance"]
    passed = report.max_deviation <= report.tolerance
    report.checks.append(Check("probes", passed,
                               f"{len(document['probes']['X'])} probe points, largest deviation "
                               f"{report.max_deviation:.3g} {'<=' if passed else '>'} tolerance {report.tolerance:.3g}"))
    return report
