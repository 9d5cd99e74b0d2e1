"""Write an ``svrqp.model/1`` document as JSON, as
the papers' coefficient table (CSV) or as C source.

* ``json`` — the document itself, indented; numbers as Python's ``repr`` (exact round trip).
* ``csv``  — S0 Table 1's layout: one row per support vector ``i, sv_coef, <inputs>``, with b,
  the kernel in every convention, C, ε and the scaling in ``#`` header comments (linear kinds: one
  row per coefficient).
* ``c``    — ``svrqp_model.c`` and ``svrqp_model.h`` (:mod:`svrqp.export.c_source`); the path is
  the ``.c`` file (the ``.h`` goes beside it) or a directory that receives both.

Files are written by :mod:`svrqp.output`, the writer every command shares: an existing file is
replaced only with ``force=True`` (the CLI's ``--force``), a symbolic link is never written through
(with ``force`` the link itself is replaced), and a FIFO, folder or device is refused.
``overwrite=`` is the former spelling of ``force=``, still accepted with a ``DeprecationWarning``.
"""

from __future__ import annotations

import csv
import io
import json
import warnings
from pathlib import Path
from typing import Any

from svrqp import output, registry
from svrqp.exceptions import ProblemError
from svrqp.export.c_source import c_source, header_source
from svrqp.export.safe_text import comment_text
from svrqp.export.schema import validate_document

FORMATS = ("json", "csv", "c")
_SUFFIX_FORMATS = {".json": "json", ".csv": "csv", ".c": "c"}
C_STEM = "svrqp_model"


def infer_format(path: str | Path) -> str:
    """The format a path's suffix asks for (``.json``, ``.csv``, ``.c``; a directory → ``c``)."""
    path = Path(path)
    if path.suffix.lower() in _SUFFIX_FORMATS:
        return _SUFFIX_FORMATS[path.suffix.lower()]
    if path.is_dir():
        return "c"
    raise ProblemError(f"format: cannot tell the format of {str(path)!r} from its suffix; "
                       f"give one of {FORMATS} (or a path ending in .json, .csv or .c)")


def json_text(document: dict[str, Any]) -> str:
    """The document as indented JSON text."""
    return json.dumps(document, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def _comments(document: dict[str, Any]) -> list[str]:
    model = document["model"]
    target = document["target"]
    lines = [f"{document['schema']} coefficient table; kind {document['kind']}",
             f"model: {model['formula']}",
             f"target: {target['name']} [{target['unit'] or '-'}]"]
    kernel = model.get("kernel")
    if kernel is not None:
        lines.append(f"b = {model['intercept']!r}")
        if kernel["name"] == "rbf":
            lines.append(f"kernel rbf: exp(-gamma |u - SV|^2), gamma = {kernel['gamma']!r}; S0: g "
                         f"= 1/sigma^2 = {kernel['g']!r}, sigma = {kernel['sigma_s0']!r}; S4 (2 "
                         f"sigma^2): sigma = {kernel['sigma_s4']!r}")
        elif kernel["name"] == "poly":
            lines.append(f"kernel poly: (gamma u.SV + coef0)^degree, gamma = {kernel['gamma']!r}, "
                         f"coef0 = {kernel['coef0']!r}, degree = {kernel['degree']}")
        else:
            lines.append("kernel linear: u.SV")
        epsilon = "" if model["epsilon"] is None else f", epsilon = {model['epsilon']!r}"
        lines.append(f"C = {model['C']!r}{epsilon}; {len(model['dual_coef'])} support vectors; "
                     "sv_coef = alpha_i* - alpha_i")
    scaling = document["scaling"]
    if scaling is not None:
        lines.append(f"scaling: u = (x - mean) / scale, mean = {scaling['mean']!r}, scale = "
                     f"{scaling['scale']!r}; the input columns below are u")
    if "interval" in document:
        interval = document["interval"]
        lines.append(f"interval: {interval['coverage']!r} conformal ({interval['method']}), "
                     "prediction +- "
                     f"{interval['quantile']!r}{' * sigma(x)' if interval['difficulty'] else ''}; "
                     "training domain and difficulty model in the JSON document")
    lines.append(f"content_sha256 of the JSON document: {document['content_sha256']}")
    return [f"# {comment_text(line)}\n" for line in lines]


def _table(document: dict[str, Any]) -> list[list[Any]]:
    model = document["model"]
    names = [v["name"] for v in document["inputs"]]
    if document["scaling"] is not None:
        names = [f"u({name})" for name in names]
    if "support_vectors" in model:
        return [["i", "sv_coef", *names]] + [
            [i, repr(beta), *(repr(v) for v in sv)]
            for i, (beta, sv) in enumerate(zip(model["dual_coef"], model["support_vectors"],
                                               strict=True), start=1)]
    if registry.formula(document["kind"]) == registry.LEGENDRE:
        return [["m", "legendre_coef"]] + [[m, repr(c)] for m, c in enumerate(model["coef"])]
    return [["term", "coef"], ["intercept", repr(model["intercept"])]] + [
        [name, repr(c)] for name, c in zip(names, model["coef"], strict=True)]


def csv_text(document: dict[str, Any]) -> str:
    """The coefficient table with its header comments."""
    buffer = io.StringIO()
    buffer.writelines(_comments(document))
    csv.writer(buffer, lineterminator="\n").writerows(_table(document))
    return buffer.getvalue()


def _targets(path: Path, fmt: str) -> list[Path]:
    if fmt != "c":
        return [path]
    source = path if path.suffix.lower() == ".c" else path / f"{C_STEM}.c"
    return [source, source.with_suffix(".h")]


def resolve_force(force: bool, overwrite: bool | None) -> bool:
    """``force``, or the deprecated ``overwrite`` when a caller still passes it."""
    if overwrite is None:
        return bool(force)
    warnings.warn("overwrite= is deprecated: use force= (the same option as the CLI's --force)",
                  DeprecationWarning, stacklevel=3)
    return bool(overwrite or force)


def write(document: dict[str, Any], path: str | Path, format: str | None = None, *,
          force: bool = False, overwrite: bool | None = None) -> list[Path]:
    """Write ``document`` to ``path`` in ``format``
    (default: from the suffix), by :mod:`svrqp.output`.

    Parameters
    ----------
    document : dict
        A valid ``svrqp.model/1`` document.
    path : str or Path
        The file (for C: the ``.c`` file or a folder that receives both files).
    format : str, optional
        One of :data:`FORMATS`.
    force : bool
        Replace existing files, or symbolic links (the link itself, never its target).
    overwrite : bool, optional
        Deprecated spelling of ``force``.

    Returns
    -------
    list of Path
        The files written (two for C: the ``.c`` and the ``.h``).

    Raises
    ------
    FileExistsError
        When a file or symbolic link to be written exists and ``force`` is false.
    ProblemError
        When a path to be written is a FIFO, a folder or a device (never opened).
    """
    force = resolve_force(force, overwrite)
    validate_document(document)
    path = Path(path)
    fmt = infer_format(path) if format is None else format
    if fmt not in FORMATS:
        raise ProblemError(f"format must be one of {FORMATS}, got {fmt!r}")
    targets = _targets(path, fmt)
    for target in targets:  # every refusal before any file is written
        output.check_target(target, force=force)
    if fmt == "json":
        texts = [json_text(document)]
    elif fmt == "csv":
        texts = [csv_text(document)]
    else:
        header = targets[1]
        guard = "".join(ch if ch.isascii() and ch.isalnum() else "_" for ch in header.name).upper()
        guard = guard if guard[0].isalpha() else f"H_{guard}"
        texts = [c_source(document, header.name), header_source(document, guard)]
    for target, text in zip(targets, texts, strict=True):
        output.write_text(target, text, force=force)
    return targets
