"""Load and verify an exported model from the file alone.

:func:`verify` runs four checks and reports each:

1. **schema** — the file's size (:data:`~svrqp.export.canonical.MAX_BYTES`), strict JSON parsing
   with nesting and number limits (no code is ever executed: no pickle, no ``eval``) and the
   ``svrqp.model/1`` JSON Schema with its shape checks
   (:func:`svrqp.export.schema.validate_document`);
2. **hash** — ``content_sha256`` recomputed from the
   canonical content (:mod:`svrqp.export.canonical`);
3. **probes** — the stored probe inputs re-evaluated from the file's numbers
   (:func:`svrqp.export.evaluate.predict`); the largest deviation from the stored predictions must
   be within the stored tolerance, and that tolerance may not exceed
   :data:`~svrqp.export.document.PROBE_RELATIVE_TOLERANCE` times the magnitude of the summed terms
   recomputed from the file (so a widened tolerance cannot hide changed coefficients);
4. **guard** — for guarded models, the interval's quantile re-derived from the stored scores, the
   domain's consistency, and the probes' intervals and out-of-domain flags re-evaluated
   (:func:`svrqp.export.guarded.guard_problems`).

Every failure is a failed check in the report, never an exception. :func:`read_document` returns a
document only when all checks pass.

What the hash proves: that the file is the one its writer hashed — no byte of its content changed by
accident or by an edit that did not recompute the hash. It is not a signature: anyone who edits a
file can recompute ``content_sha256`` (and the probe predictions), so it says nothing about who
wrote the file.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from svrqp.exceptions import ProblemError
from svrqp.export import canonical, evaluate, guarded
from svrqp.export.schema import validate_document

#: Probe tolerance relative to the magnitude of the summed terms (see evaluate.term_magnitude):
#: far above reordering round-off (~1e-15), far below any change a reader would care about.
PROBE_RELATIVE_TOLERANCE = 1e-9

#: Slack on the recomputed tolerance bound: the magnitude is re-summed in another order.
_BOUND_SLACK = 1.0 + 1e-9


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
        """True when every check ran and passed."""
        return len(self.checks) == len(CHECKS) and all(check.ok for check in self.checks)

    def failures(self) -> str:
        """The failed checks as one line (empty when none failed)."""
        return "; ".join(f"{check.name}: {check.detail}" for check in self.checks if not check.ok)


def _parse(path: Path) -> dict[str, Any]:
    """Read, parse and schema-check ``path``; every problem is a ProblemError naming the file."""
    try:
        if not path.is_file():  # a directory, a FIFO or a device would block or fail the read
            raise ProblemError("not a regular file")
        size = path.stat().st_size
        if size > canonical.MAX_BYTES:
            raise ProblemError(f"file has {size} bytes, more than the {canonical.MAX_BYTES} a "
                               f"model file may have")
        document = canonical.parse_strict(path.read_bytes().decode("utf-8"))
        validate_document(document)
        canonical.canonical_bytes(document)  # every string must be encodable to be hashed
    except (ProblemError, UnicodeDecodeError, OSError) as err:
        raise ProblemError(f"{path}: {err}") from None
    return document


def _checked_points(document: dict[str, Any]) -> list[tuple[np.ndarray, np.ndarray]]:
    """(raw inputs, stored predictions): the probes, and for kernel models every support vector."""
    probes = document["probes"]
    points = [(np.asarray(probes["X"], dtype=float), np.asarray(probes["prediction"], dtype=float))]
    if "support_prediction" in probes:
        points.append((evaluate.support_inputs(document),
                       np.asarray(probes["support_prediction"], dtype=float)))
    return points


def probe_deviation(document: dict[str, Any]) -> float:
    """Largest |stored − re-evaluated| prediction over the probe points and, for kernel models, the
    support vectors (``inf`` if not finite)."""
    largest = 0.0
    with np.errstate(all="ignore"):
        for X, stored in _checked_points(document):
            deviation = np.abs(evaluate.predict(document, X) - stored)
            if not np.all(np.isfinite(deviation)):
                return float("inf")
            largest = max(largest, float(deviation.max(initial=0.0)))
    return largest


def tolerance_bound(document: dict[str, Any]) -> float:
    """The largest probe tolerance the file's own terms justify (``inf`` if they overflow)."""
    with np.errstate(all="ignore"):
        magnitude = max(float(evaluate.term_magnitude(document, X).max(initial=0.0))
                        for X, _ in _checked_points(document))
    return (
        PROBE_RELATIVE_TOLERANCE * max(1.0, magnitude) * _BOUND_SLACK
        if np.isfinite(magnitude)
        else 0.0
    )


def _check_hash(document: dict[str, Any], report: VerifyReport) -> Check:
    stored = document["content_sha256"]
    recomputed = canonical.content_sha256(document)
    if stored == recomputed:
        return Check("hash", True, f"content_sha256 {stored}")
    return Check("hash", False, f"content_sha256 stored {stored}, recomputed {recomputed}")


def _check_probes(document: dict[str, Any], report: VerifyReport) -> Check:
    report.tolerance = tolerance = document["probes"]["tolerance"]
    report.max_deviation = probe_deviation(document)
    passed = report.max_deviation <= tolerance
    support = len(document["probes"].get("support_prediction", ()))
    detail = (f"{len(document['probes']['X'])} probe "
              f"points{f' and {support} support vectors' if support else ''}, largest deviation "
              f"{report.max_deviation:.3g} {'<=' if passed else '>'} tolerance {tolerance:.3g}")
    bound = tolerance_bound(document)
    if not tolerance <= bound:
        return Check("probes", False, f"{detail}; but the tolerance exceeds "
                                      f"{PROBE_RELATIVE_TOLERANCE:g} x the "
                                      f"magnitude of the model's terms at the probes ({bound:.3g})")
    return Check("probes", passed, detail)


def _check_guard(document: dict[str, Any], report: VerifyReport) -> Check:
    if "interval" not in document:
        return Check("guard", True, "no interval or domain (not a guarded model)")
    problems = guarded.guard_problems(document, document["probes"]["tolerance"])
    if problems:
        return Check("guard", False, "; ".join(problems))
    interval = document["interval"]
    return Check("guard", True, f"{interval['coverage']:g} {interval['method']} interval, quantile "
                                f"{interval['quantile']:.4g} = conformal order statistic of "
                                f"{len(interval['scores'])} "
                                "scores; domain and probe intervals reproduced")


#: The checks, in order; each after the schema sees the parsed document and the report so far.
CHECKS: tuple[str, ...] = ("schema", "hash", "probes", "guard")
_DOCUMENT_CHECKS: tuple[Callable[[dict[str, Any], VerifyReport], Check], ...] = (
    _check_hash, _check_probes, _check_guard,
)


def _verified(path: Path) -> tuple[VerifyReport, dict[str, Any] | None]:
    """The report of every check and the parsed document (None when it could not be parsed)."""
    report = VerifyReport(str(path))
    try:
        document = _parse(path)
    except ProblemError as err:
        report.checks.append(Check("schema", False, str(err)))
        return report, None
    report.checks.append(Check("schema", True, f"valid {document['schema']} ({document['kind']})"))
    for check in _DOCUMENT_CHECKS:
        report.checks.append(check(document, report))
    return report, document


def verify(path: str | Path) -> VerifyReport:
    """Verify the model file at ``path``: size and
    schema, content hash, probe predictions, guard."""
    return _verified(Path(path))[0]


def read_document(path: str | Path) -> dict[str, Any]:
    """Load a model file after verifying it (schema, content hash, probes); errors name the file.

    Raises
    ------
    ProblemError
        When the file is not JSON, not a valid ``svrqp.model/1`` document, its content does not
        match its hash, or its model does not reproduce its probe predictions.
    FileNotFoundError
        When the file does not exist.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"model file not found: {path}")
    report, document = _verified(path)
    if not report.ok:
        raise ProblemError(f"{path} fails verification: {report.failures()}")
    return document
