"""Assemble a fitted model into an ``svrqp.model/1`` document (a plain ``dict``) and check it.

The document is built from the model's own fitted attributes (:mod:`svrqp.export.describe`), the
training data's hash, the export-time cross-check (:mod:`svrqp.export.crosscheck`) and probe points
predicted by the live model; it is validated against the schema before it is returned, and its
``content_sha256`` is computed last (:mod:`svrqp.export.canonical`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from datetime import UTC, datetime
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from svrqp import registry
from svrqp._version import __version__
from svrqp.exceptions import ExtrapolationWarning, ProblemError
from svrqp.export import canonical, crosscheck, describe, evaluate, guarded
from svrqp.export.budget import check_budget
from svrqp.export.schema import SCHEMA_ID, validate_document
from svrqp.export.verify import PROBE_RELATIVE_TOLERANCE
from svrqp.units import unit_from_name

#: How many probe points a document stores when the caller gives none.
N_PROBES = 16


def _names(given: Sequence[str] | None, X: Any, model: Any, d: int) -> list[str]:
    if given is not None:
        names = [str(name) for name in given]
    elif isinstance(X, pd.DataFrame):
        names = [str(name) for name in X.columns]
    elif hasattr(model, "feature_names_in_"):
        names = [str(name) for name in model.feature_names_in_]
    else:
        names = [f"x{j}" for j in range(d)]
    if len(names) != d:
        raise ProblemError(f"feature_names: {len(names)} names for a model with {d} inputs")
    return names


def _variables(names: list[str], units: Sequence[str | None] | None) -> list[dict[str, Any]]:
    if units is None:
        units = [unit_from_name(name) for name in names]
    if len(units) != len(names):
        raise ProblemError(f"feature_units: {len(units)} units for {len(names)} inputs")
    return [{"name": name, "unit": unit} for name, unit in zip(names, units, strict=True)]


def _as_model_input(model: Any, X: NDArray[np.float64]) -> Any:
    """Give ``X`` the column names the model was fitted with, so predict sees what fit saw."""
    if hasattr(model, "feature_names_in_"):
        return pd.DataFrame(X, columns=model.feature_names_in_)
    return X


def _probe_inputs(document: dict[str, Any], X: NDArray[np.float64] | None) -> NDArray[np.float64]:
    if X is not None:
        # Enough probes to pin a linear model (d + 1) or
        # a polynomial (degree + 1), at least N_PROBES.
        count = max(N_PROBES, len(document["inputs"]) + 1,
                    int(document["model"].get("degree") or 0) + 1)
        rows = np.unique(np.linspace(0, len(X) - 1, min(count, len(X))).round().astype(int))
        return X[rows]
    support_vectors = document["model"].get("support_vectors")
    if support_vectors is None:
        raise ProblemError("X: training inputs are needed to choose probe points for a model "
                           "without support vectors (or pass probes=...)")
    U = np.asarray(support_vectors)[:N_PROBES]
    scaling = document["scaling"]
    return U if scaling is None else U * np.asarray(scaling["scale"]) + np.asarray(scaling["mean"])


def _checked_data(X: ArrayLike | None, y: ArrayLike | None,
                  d: int) -> tuple[NDArray | None, NDArray | None]:
    if (X is None) != (y is None):
        raise ProblemError("X and y: give both (the training data) or neither")
    if X is None:
        return None, None
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float).ravel()
    if X.ndim != 2 or X.shape[1] != d or len(y) != len(X):
        raise ProblemError(f"X, y: expected shapes (n, {d}) and (n,), got {X.shape} and {y.shape}")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(y))):
        raise ProblemError("X, y: the training data must be finite")
    return X, y


def build_document(
    model: Any,
    X: ArrayLike | None = None,
    y: ArrayLike | None = None,
    *,
    feature_names: Sequence[str] | None = None,
    feature_units: Sequence[str | None] | None = None,
    target_name: str | None = None,
    target_unit: str | None = None,
    probes: ArrayLike | None = None,
) -> dict[str, Any]:
    """Describe a fitted model as a validated ``svrqp.model/1`` document.

    Parameters
    ----------
    model
        A fitted svrqp estimator, a ``Pipeline(StandardScaler, estimator)``, or a
        :class:`svrqp.Guarded` wrapping either (the document then also holds the interval and
        the domain, :mod:`svrqp.export.guarded`).
    X, y
        The training data, in raw units. When given, the document records their SHA-256 and the
        cross-check against an independent reference fitted on them; without them both are null.
    feature_names, feature_units
        Input names and units; by default from ``X``'s columns or the model's
        ``feature_names_in_`` and the unit suffixes of
        those names (:func:`svrqp.units.unit_from_name`).
    target_name, target_unit
        Target name (default: ``y.name`` or ``"y"``) and unit (default: from the name).
    probes
        Raw inputs at which predictions are stored for ``verify``; by default up to
        :data:`N_PROBES` rows of ``X`` (or of the support vectors).

    Returns
    -------
    dict
        The document, schema-checked, with ``content_sha256`` set.
    """
    outer = model
    if guarded.is_guarded(model):
        model = model.estimator_  # the model that predicts; the interval and domain come from outer
    scaling, estimator = describe.split_pipeline(model)
    kind = describe.kind_of(estimator)
    section, solver, centre = describe.sections(estimator)
    scaling = describe.with_centre(scaling, centre)
    d = int(estimator.n_features_in_)
    names = _names(feature_names, X, outer, d)
    if target_name is None:
        target_name = str(y.name) if isinstance(y, pd.Series) and y.name is not None else "y"
    X_raw, y_raw = _checked_data(X, y, d)
    document: dict[str, Any] = {
        "schema": SCHEMA_ID,
        "kind": kind,
        "library": {"name": "svrqp", "version": __version__},
        "created_utc": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "inputs": _variables(names, feature_units),
        "target": {"name": target_name,
                   "unit": target_unit if target_unit is not None else unit_from_name(target_name)},
        "scaling": scaling,
        "model": section,
        "training_data": None,
        "solver": solver,
        "cross_check": None,
    }
    if X_raw is not None:
        document["training_data"] = {"sha256": canonical.data_sha256(X_raw, y_raw),
                                     "n_samples": len(y_raw),
                                     "n_features": d, "definition": canonical.DATA_HASH_DEFINITION}
        prediction = model.predict(_as_model_input(model, X_raw))
        document["cross_check"] = crosscheck.cross_check(
            kind, section, evaluate.model_coordinates(document, X_raw), y_raw, prediction)
    probe_X = _probe_inputs(document, X_raw) if probes is None else np.asarray(probes, dtype=float)
    document["probes"] = _probes(document, model, probe_X)
    if outer is not model:
        _add_guard(document, outer, probe_X)
    document["content_sha256"] = canonical.content_sha256(document)
    validate_document(document)
    return document


def _probes(document: dict[str, Any], model: Any, probe_X: NDArray[np.float64]) -> dict[str, Any]:
    """The probes section: the live model's predictions at the probe inputs and, for kernel models,
    at every support vector (which pins every dual coefficient, see :mod:`svrqp.export.verify`)."""
    check_budget({"probes": {"X": list(probe_X)}, "model": document["model"]})
    checked = [probe_X]
    section: dict[str, Any] = {"X": [describe.floats(row) for row in probe_X],
                               "prediction": describe.floats(_predicted(model, probe_X))}
    if registry.formula(document["kind"]) == registry.KERNEL:
        support_X = evaluate.support_inputs(document)
        section["support_prediction"] = describe.floats(_predicted(model, support_X))
        checked.append(support_X)
    magnitude = max(float(evaluate.term_magnitude(document, points).max(initial=0.0))
                    for points in checked)
    section["tolerance"] = PROBE_RELATIVE_TOLERANCE * max(1.0, magnitude)
    return section


def _predicted(model: Any, X: NDArray[np.float64]) -> NDArray[np.float64]:
    """``model.predict(X)`` by row blocks (a kernel model's Gram block stays small)."""
    m = len(getattr(model, "support_", ())) or 1
    blocks = evaluate.row_blocks(len(X), m) or [slice(0, 0)]
    return np.concatenate(
        [
            np.asarray(model.predict(_as_model_input(model, X[rows])), dtype=float).ravel()
            for rows in blocks
        ]
    )


def _add_guard(document: dict[str, Any], model: Any, probe_X: NDArray[np.float64]) -> None:
    """The interval and domain sections, and the probes' intervals and flags from the live model."""
    document.update(guarded.sections(model))
    with warnings.catch_warnings():
        # probes may be chosen outside on purpose
        warnings.simplefilter("ignore", ExtrapolationWarning)
        interval = model.predict_interval(_as_model_input(model, probe_X))
    document["probes"]["lower"] = describe.floats(interval[:, 0])
    document["probes"]["upper"] = describe.floats(interval[:, 1])
    document["probes"]["outside"] = [bool(flag) for flag in model.domain_.outside(probe_X)]
