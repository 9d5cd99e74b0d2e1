"""Read a fitted model into the plain-data sections of an ``svrqp.model/1`` document.

A model is either a fitted svrqp estimator or a scikit-learn ``Pipeline`` of a ``StandardScaler``
followed by one. :func:`split_pipeline` separates the scaling (recorded so the file alone maps raw
inputs to the model's coordinates ``u = (x - mean) / scale``) from the estimator.

Each exportable estimator describes itself through the protocol of :mod:`svrqp.description`
(:class:`~svrqp.description.Describable`): its class attribute ``export_kind`` is the document's
``kind`` and its ``export_sections()`` returns the ``model`` section (its coefficients) and the
``solver`` section (how they were computed). :func:`kind_of` and :func:`sections` read it; this
package never imports an estimator, and no estimator imports this package.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import check_is_fitted

from svrqp import registry
from svrqp.description import Describable, Sections, floats
from svrqp.exceptions import ProblemError


def split_pipeline(model: Any) -> tuple[dict[str, Any] | None, Any]:
    """Return ``(scaling section or None, final estimator)`` of ``model``.

    Raises
    ------
    ProblemError
        For a pipeline step other than one leading ``StandardScaler``.
    """
    if not isinstance(model, Pipeline):
        return None, model
    steps = [step for _, step in model.steps if step not in (None, "passthrough")]
    *transforms, estimator = steps
    if len(transforms) > 1 or (transforms and not isinstance(transforms[0], StandardScaler)):
        names = [type(step).__name__ for step in transforms]
        raise ProblemError(f"model: only a pipeline StandardScaler → estimator can be exported, "
                           f"got steps {names}")
    if not transforms:
        return None, estimator
    scaler = transforms[0]
    check_is_fitted(scaler)
    d = scaler.n_features_in_
    mean = scaler.mean_ if scaler.mean_ is not None else np.zeros(d)
    scale = scaler.scale_ if scaler.scale_ is not None else np.ones(d)
    return {"method": "standard", "mean": floats(mean), "scale": floats(scale)}, estimator


def with_centre(scaling: dict[str, Any] | None, centre: Any) -> dict[str, Any] | None:
    """The ``scaling`` section that also subtracts a model's own input centre (in the model's
    coordinates): :math:`u = (x - m)/s - c = (x - (m + s c))/s`."""
    if centre is None:
        return scaling
    centre = np.asarray(centre, dtype=float)
    if scaling is None:
        return {"method": "standard", "mean": floats(centre), "scale": floats(np.ones_like(centre))}
    scale = np.asarray(scaling["scale"], dtype=float)
    return {**scaling, "mean": floats(np.asarray(scaling["mean"], dtype=float) + scale * centre)}


def kind_of(estimator: Any) -> str:
    """The ``kind`` of an exportable estimator (its
    ``export_kind``, :class:`~svrqp.description.Describable`)."""
    if not isinstance(estimator, Describable):
        exportable = ", ".join(model.class_name for model in registry.MODELS)
        raise ProblemError(f"model: cannot export a {type(estimator).__name__}; exportable: "
                           f"{exportable} (alone or after a StandardScaler)")
    return estimator.export_kind


def sections(estimator: Any) -> Sections:
    """The ``model`` and ``solver`` sections of a fitted exportable estimator."""
    check_is_fitted(estimator)
    return estimator.export_sections()
