"""The report's data and its JSON document: what :func:`svrqp.gap.diagnose` returns, as data.

:class:`GapResult` holds the keys of the ``svrqp.gap/2`` document (:meth:`GapResult.to_dict`),
validated against the published schema ``svrqp/gap/gap.schema.json`` (shipped in the package):
a document that fails it is never returned. Non-finite numbers become ``null``.
:func:`read_document` reads a written document of this version or of the previous one,
``svrqp.gap/1`` (validated against its own schema, ``gap-1.schema.json``): that version also
carried ``causes[].round`` (always 1) and ``causes[].p_paired`` (never set), dropped since.
The renderings and the file writer are in :mod:`svrqp.gap.words.report`.
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import asdict, dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema

from svrqp.exceptions import SvrqpError
from svrqp.gap.results.records import BaseFit, Cause, GateResult, InputUse, Region, Series, Verdict

SCHEMA_ID = "svrqp.gap/2"
"""The version this package writes."""

SCHEMA_FILES = {"svrqp.gap/2": "gap.schema.json", "svrqp.gap/1": "gap-1.schema.json"}
"""Every version this package reads, and its schema file (in ``svrqp/gap``)."""


def load_schema(version: str = SCHEMA_ID) -> dict:
    """The JSON Schema of ``version`` (by default the one written, ``svrqp.gap/2``).

    Parameters
    ----------
    version : str
        A key of :data:`SCHEMA_FILES`.

    Returns
    -------
    dict
        The schema.
    """
    if version not in SCHEMA_FILES:
        raise SvrqpError(f"unknown gap report schema {version!r}: this package reads "
                         f"{sorted(SCHEMA_FILES)}")
    text = resources.files("svrqp.gap").joinpath(SCHEMA_FILES[version]).read_text(encoding="utf-8")
    return json.loads(text)


def validate_document(document: dict[str, Any]) -> dict[str, Any]:
    """Check a gap document against the schema of the version it names; return it unchanged.

    Parameters
    ----------
    document : dict
        A parsed ``svrqp.gap/2`` or ``svrqp.gap/1`` document.

    Returns
    -------
    dict
        ``document``.

    Raises
    ------
    SvrqpError
        If it names no known version or fails its schema.
    """
    version = document.get("schema") if isinstance(document, dict) else None
    validator = _validator(version if isinstance(version, str) else "")
    error = jsonschema.exceptions.best_match(validator.iter_errors(document))
    if error is not None:
        raise SvrqpError(f"gap report fails its schema {version} at {list(error.absolute_path)}: "
                         f"{error.message}") from error
    return document


@functools.cache
def _validator(version: str) -> jsonschema.protocols.Validator:
    """The validator of ``version``'s schema, the schema itself checked once per process.

    ``jsonschema.validate`` checks the schema against its metaschema on every call, which took
    most of a document's validation time (and a third of a small record's diagnosis); this is
    the same check and the same first error (``best_match``), made once.
    """
    schema = load_schema(version)
    cls = jsonschema.validators.validator_for(schema)
    cls.check_schema(schema)
    return cls(schema)


def read_document(path: str | Path) -> dict[str, Any]:
    """Read and validate a written gap document (``svrqp.gap/2``, or the previous ``svrqp.gap/1``).

    Parameters
    ----------
    path : str or Path
        The JSON file.

    Returns
    -------
    dict
        The document as written (a ``svrqp.gap/1`` one keeps its ``round`` and ``p_paired``).
    """
    try:
        document = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as err:
        raise SvrqpError(f"{path}: not a JSON gap report ({err})") from err
    return validate_document(document)


@dataclass
class GapResult:
    """The data of a diagnosis (:func:`svrqp.gap.diagnose` returns it as a
    :class:`svrqp.gap.GapReport`, which adds the renderings and the writer).

    The attributes mirror the keys of the ``svrqp.gap/2`` JSON (:meth:`to_dict`); ``series``
    holds the per-row data the figures draw and ``pool_p`` the p-values pooled by ``svrqp
    fleet``; neither is part of the JSON.
    """

    target: str
    mode: str
    model: str | None
    features: list[str]
    prediction: str | None
    candidates: list[str]
    order: str
    group: str | None
    n_rows: int
    n_train: int
    n_real: int
    n_dropped: int
    n_dropped_short_groups: int
    gap: GateResult
    gap_detected: bool
    where: list[Region]
    causes: list[Cause]
    verdict: Verdict
    residual_gate: GateResult | None
    remaining: list[str]
    base: BaseFit
    inputs: list[InputUse]
    summary: str
    transfer: dict[str, Any]
    blocks: dict[str, Any] | None
    settings: dict[str, Any]
    runtime_s: float
    series: Series = field(repr=False)
    order_sorted: list[str] = field(default_factory=list)
    pool_p: dict[str, float] | None = field(default=None, repr=False)
    """Every candidate's transfer-test p-value for pooling over records
    (:mod:`svrqp.gap.transfer.pooling`; ``diagnose(pool=True)`` only): not part of the JSON."""

    def to_dict(self) -> dict[str, Any]:
        """The ``svrqp.gap/2`` document as plain Python (validated against the schema)."""
        gap = asdict(self.gap)
        gap["detected"] = self.gap_detected
        residual_gate = None
        if self.residual_gate is not None:
            g = self.residual_gate
            residual_gate = {"real_rmse": g.real_rmse, "ratio": g.ratio, "p_excess": g.p_excess,
                             "p_white": g.p_white, "remaining": list(self.remaining)}
        document = {
            "schema": SCHEMA_ID,
            "target": self.target,
            "mode": self.mode,
            "model": self.model,
            "features": list(self.features),
            "prediction": self.prediction,
            "candidates": list(self.candidates),
            "order": self.order,
            "group": self.group,
            "n_rows": self.n_rows,
            "n_train": self.n_train,
            "n_real": self.n_real,
            "n_dropped": self.n_dropped,
            "n_dropped_short_groups": self.n_dropped_short_groups,
            "order_sorted": list(self.order_sorted),
            "gap": gap,
            "where": [asdict(r) for r in self.where],
            "causes": [asdict(c) for c in self.causes],
            "verdict": asdict(self.verdict),
            "residual_gate": residual_gate,
            "base": asdict(self.base),
            "transfer": self.transfer,
            "blocks": self.blocks,
            "inputs": [asdict(u) | {"extrapolated": u.extrapolated} for u in self.inputs],
            "summary": self.summary,
            "settings": self.settings,
            "runtime_s": self.runtime_s,
        }
        return validate_document(_finite(document))

    def to_json(self, indent: int = 2) -> str:
        """The schema-valid ``svrqp.gap/2`` JSON text."""
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)


def _finite(value: Any) -> Any:
    """Replace non-finite floats by None, tuples by lists, numpy scalars by Python ones."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
