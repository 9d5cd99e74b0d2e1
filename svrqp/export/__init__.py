"""Auditable model export: the ``svrqp.model/1`` JSON document, CSV coefficient table, C evaluator.

Pipeline: fitted model → :func:`build_document` (a plain, schema-checked ``dict`` with a content
hash) → :func:`write` (``json`` | ``csv`` | ``c``); :func:`verify` checks a JSON file from the file
alone; :func:`read_document` loads one only after the same checks (never executes code);
:func:`predict` evaluates a loaded document. The JSON Schema ships as ``model.schema.json`` in
this package (:func:`load_schema`). The contract is the export format page of the documentation
(``docs/export.md``).
"""

from __future__ import annotations

from svrqp.export.canonical import canonical_bytes, content_sha256, data_sha256
from svrqp.export.document import build_document
from svrqp.export.evaluate import predict
from svrqp.export.mixin import export_model
from svrqp.export.schema import SCHEMA_ID, load_schema, validate_document
from svrqp.export.verify import VerifyReport, read_document, verify
from svrqp.export.writers import FORMATS, write
from svrqp.units import unit_from_name

__all__ = [
    "FORMATS",
    "SCHEMA_ID",
    "VerifyReport",
    "build_document",
    "canonical_bytes",
    "content_sha256",
    "data_sha256",
    "export_model",
    "load_schema",
    "predict",
    "read_document",
    "unit_from_name",
    "validate_document",
    "verify",
    "write",
]
