"""What a model file may ask of ``verify``: counts
checked before any schema validation or evaluation.

``verify`` re-evaluates the model at every stored probe and support vector, so its work grows with
(probes + support vectors) × support vectors × inputs, and with the polynomial kernel's degree. A
file can ask for any of these; the limits below are far above any model svrqp fits for a machine
tool and are checked on the parsed document in microseconds, before the JSON Schema (whose validator
walks every number) and before a single kernel value is computed. A file over a limit fails the
schema check with a message naming the field.
"""

from __future__ import annotations

from typing import Any

from svrqp.exceptions import ProblemError
from svrqp.kernels import MAX_DEGREE

#: Most stored probe points (the exporter stores 16, or one more than the inputs of a linear model).
MAX_PROBES = 1_000
#: Most support vectors in a model file: verify evaluates the model at each of them, about 3 s on
#: one core for 10 000 support vectors of 20 inputs (the export refuses larger models too).
MAX_SUPPORT_VECTORS = 10_000
#: Most inputs of a model.
MAX_INPUTS = 1_000
#: Most calibration scores of a guarded model (one per training row).
MAX_SCORES = 1_000_000

_PROBE_LISTS = ("X", "prediction", "lower", "upper", "outside")


def _length(value: Any) -> int:
    return len(value) if isinstance(value, list) else 0


def _refuse(field: str, count: int, limit: int, what: str) -> None:
    if count > limit:
        raise ProblemError(f"{field}: has {count} {what}, more than the {limit} a model file may "
                           f"have")


def check_budget(document: Any) -> None:
    """Raise :class:`ProblemError` naming the first field over a limit of this module.

    Only lengths and the kernel degree are read (no number is validated here), so the check costs
    microseconds whatever the file holds; a document of the wrong shape is left to the schema.
    """
    if not isinstance(document, dict):
        return
    _refuse("inputs", _length(document.get("inputs")), MAX_INPUTS, "inputs")
    probes = document.get("probes")
    if isinstance(probes, dict):
        for key in (*_PROBE_LISTS, "support_prediction"):
            limit = MAX_SUPPORT_VECTORS if key == "support_prediction" else MAX_PROBES
            _refuse(f"probes.{key}", _length(probes.get(key)), limit, "entries")
    model = document.get("model")
    if isinstance(model, dict):
        for key in ("support_vectors", "dual_coef"):
            _refuse(f"model.{key}", _length(model.get(key)), MAX_SUPPORT_VECTORS, "entries")
        _refuse("model.coef", _length(model.get("coef")), max(MAX_INPUTS, MAX_DEGREE + 1),
                "entries")
        degree = model.get("degree")
        kernel = model.get("kernel")
        if isinstance(kernel, dict):
            degree = kernel.get("degree") if kernel.get("degree") is not None else None
        if isinstance(degree, int) and not isinstance(degree,
                                                      bool) and not 0 <= degree <= MAX_DEGREE:
            field = "model.kernel.degree" if isinstance(kernel, dict) else "model.degree"
            raise ProblemError(f"{field}: is {degree}; a model file's degree is at most "
                               f"{MAX_DEGREE}")
    interval = document.get("interval")
    if isinstance(interval, dict):
        _refuse("interval.scores", _length(interval.get("scores")), MAX_SCORES, "entries")
