"""``model.export(path)``: the export entry point shared by every exportable estimator."""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar


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

    return write(build_document(model, **document), path, format, force=resolve_force(force, overwrite))


class ExportMixin:
    """Adds :meth:`export` to an estimator (``class EpsilonSVR(ExportMixin, _KernelModel)``).

    An exportable estimator describes itself, so that this package never imports an estimator:

    * ``_export_kind`` (class attribute): the ``kind`` of its documents, one of
      :func:`svrqp.registry.export_kinds`;
    * ``_export_sections()``: the ``model`` and ``solver`` sections of the fitted estimator, a
      :class:`svrqp.export.describe.Sections` built with the helpers of
      :mod:`svrqp.export.describe`.
    """

    _export_kind: ClassVar[str]

    def export(self, path: str | Path, format: str | None = None, **options: Any) -> list[Path]:
        """Write this fitted model as an auditable ``svrqp.model/1`` JSON, a CSV table or C source.

        ``options`` are the keyword arguments of :func:`svrqp.export.export_model` (``X``, ``y``,
        ``feature_names``, ``feature_units``, ``target_name``, ``target_unit``, ``probes``,
        ``force``), forwarded unchanged, so the two cannot drift apart.
        """
        return export_model(self, path, format, **options)
