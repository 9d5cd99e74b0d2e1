"""The ``svrqp.model/1`` JSON Schema (package data
``model.schema.json``) and the checks on a document.

:func:`validate_document` checks the counts of :mod:`svrqp.export.budget` first, then runs the JSON
Schema (with the ``jsonschema`` library) and then the cross-field shape checks a schema cannot state
(every vector has one entry per input, one coefficient per support vector, ...). Every failure
raises :class:`~svrqp.exceptions.ProblemError` whose message starts with the offending field, e.g.
``model.dual_coef[3]: 'x' is not of type 'number'``.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from datetime import datetime
from functools import cache
from importlib.resources import files
from typing import Any

import jsonschema
from jsonschema.exceptions import best_match

from svrqp import registry
from svrqp.exceptions import ProblemError
from svrqp.export.budget import check_budget

SCHEMA_ID = "svrqp.model/1"
SCHEMA_RESOURCE = "model.schema.json"


@cache
def load_schema() -> dict[str, Any]:
    """The JSON Schema of ``svrqp.model/1`` as shipped in the package."""
    return json.loads(files("svrqp.export").joinpath(SCHEMA_RESOURCE).read_text(encoding="utf-8"))


@cache
def _validator() -> jsonschema.Draft202012Validator:
    schema = load_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def field_name(path: Iterable[str | int]) -> str:
    """``["model", "dual_coef", 3]`` → ``"model.dual_coef[3]"`` (``"<document>"`` for the root)."""
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "<document>"


def _fail(field: str, message: str) -> None:
    raise ProblemError(f"{field}: {message}")


def _check_length(field: str, values: list, expected: int, what: str) -> None:
    if len(values) != expected:
        _fail(field, f"has {len(values)} entries, expected {expected} ({what})")


def _check_created(text: str) -> None:
    try:
        datetime.strptime(text, "%Y-%m-%dT%H:%M:%SZ")
    except ValueError:
        _fail("created_utc", f"{text!r} is not a real date and time (YYYY-MM-DDTHH:MM:SSZ, UTC)")


def _check_guard_shapes(document: dict[str, Any], d: int) -> None:
    """A guarded document has both sections and the probes' intervals; others have none of them."""
    guarded = [key for key in ("interval", "domain") if key in document]
    probe_keys = [key for key in ("lower", "upper", "outside") if key in document["probes"]]
    if not guarded:
        if probe_keys:
            _fail(f"probes.{probe_keys[0]}", "is only allowed with an interval and a domain")
        return
    if len(guarded) == 1:
        _fail(guarded[0], "comes with its partner: give both interval and domain, or neither")
    for key in ("lower", "upper", "outside"):
        if key not in probe_keys:
            _fail("probes", f"a guarded document stores the probes' {key!r}")
        _check_length(f"probes.{key}", document["probes"][key], len(document["probes"]["X"]),
                      "one per probe input")
    domain = document["domain"]
    per_input = f"one per input, {d} inputs"
    for key in ("low", "high", "mean", "scale", "precision"):
        _check_length(f"domain.{key}", domain[key], d, per_input)
    for i, row in enumerate(domain["precision"]):
        _check_length(f"domain.precision[{i}]", row, d, per_input)
    if document["interval"]["difficulty"] is not None:
        _check_length("interval.difficulty.coef", document["interval"]["difficulty"]["coef"], d,
                      per_input)
    if (document["interval"]["method"] == "normalized") != (
        document["interval"]["difficulty"] is not None
    ):
        _fail("interval.difficulty", "is given exactly when method is 'normalized'")


def _check_shapes(document: dict[str, Any]) -> None:
    _check_created(document["created_utc"])
    d = len(document["inputs"])
    per_input = f"one per input, {d} inputs"
    if document["scaling"] is not None:
        for key in ("mean", "scale"):
            _check_length(f"scaling.{key}", document["scaling"][key], d, per_input)
    if document["training_data"] is not None and document["training_data"]["n_features"] != d:
        _fail("training_data.n_features", f"is {document['training_data']['n_features']}, expected "
                                          f"{d} ({per_input})")
    model = document["model"]
    formula = registry.formula(document["kind"])
    if formula == registry.KERNEL:
        for i, row in enumerate(model["support_vectors"]):
            _check_length(f"model.support_vectors[{i}]", row, d, per_input)
        _check_length("model.dual_coef", model["dual_coef"], len(model["support_vectors"]),
                      "one per support vector")
        if not model["fit_intercept"] and model["intercept"] != 0.0:
            _fail("model.intercept", "must be 0 when fit_intercept is false")
        if "support_prediction" not in document["probes"]:
            _fail("probes", "a kernel model stores the prediction at every support vector "
                            "('support_prediction')")
        _check_length("probes.support_prediction", document["probes"]["support_prediction"],
                      len(model["support_vectors"]), "one per support vector")
    elif formula == registry.LEGENDRE:
        if d != 1:
            _fail("inputs", f"a polynomial model has exactly one input, got {d}")
        _check_length("model.coef", model["coef"], model["degree"] + 1, "degree + 1 Legendre "
                                                                        "coefficients")
        low, high = model["domain"]
        if not low < high:
            _fail("model.domain", f"must be increasing, got [{low}, {high}]")
    else:
        _check_length("model.coef", model["coef"], d, per_input)
    if formula != registry.KERNEL and "support_prediction" in document["probes"]:
        _fail("probes.support_prediction", "is only allowed for a model with support vectors")
    _check_guard_shapes(document, d)
    probes = document["probes"]
    for i, row in enumerate(probes["X"]):
        _check_length(f"probes.X[{i}]", row, d, per_input)
    _check_length("probes.prediction", probes["prediction"], len(probes["X"]),
                  "one per probe input")


def validate_document(document: Any) -> None:
    """Check ``document`` against the ``svrqp.model/1`` schema and its cross-field shapes.

    Raises
    ------
    ProblemError
        Naming the first offending field and what is wrong with it.
    """
    if not isinstance(document, dict):
        _fail("<document>", f"must be a JSON object, got {type(document).__name__}")
    if document.get("schema") != SCHEMA_ID:
        _fail("schema", f"must be {SCHEMA_ID!r}, got {document.get('schema')!r}")
    check_budget(document)  # counts and degree first: the schema validator walks every number
    error = best_match(_validator().iter_errors(document))
    if error is not None:
        _fail(field_name(error.absolute_path), error.message)
    _check_shapes(document)
