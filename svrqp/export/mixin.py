"""``export_model(model, path)``: the export entry point of every exportable model.

A model is exportable when its estimator describes itself (:class:`svrqp.description.Describable`);
the estimators do not import this package, so the entry point takes the model as its argument.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


def export_model(
    model: Any,
    path: str | Path,
    format: str | None = None,
    *,
    force: bool = False,
    overwrite: bool | None = None,
    **document: Any,
) -> list[Path]:
    """Export a fitted model (an estimator or a ``Pipeline(StandardScaler, estimator)``).

    Parameters
    ----------
    model
        The fitted model.
    path
        Output file (``.json``, ``.csv``, ``.c``) or, for C, a directory.
    format
        ``"json"``, ``"csv"`` or ``"c"``; default: from the suffix of ``path``.
    force
        Replace existing files (default: refuse with ``FileExistsError``); see :mod:`svrqp.output`.
    overwrite
        Deprecated spelling of ``force`` (a ``DeprecationWarning``).
    **document
        The keyword arguments of :func:`svrqp.export.document.build_document`, forwarded
        unchanged: ``X``, ``y`` (the training data: its hash and the scikit-learn cross-check),
        ``feature_names``, ``feature_units``, ``target_name``, ``target_unit``, ``probes``.

    Returns
    -------
    list of Path
        The files written.
    """
    from svrqp.export.document import build_document
    from svrqp.export.writers import resolve_force, write

    return write(build_document(model, **document), path, format,
                 force=resolve_force(force, overwrite))

