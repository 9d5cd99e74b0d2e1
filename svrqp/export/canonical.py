"""Canonical JSON, content hash and training-data hash of an exported model.

Canonical form (what ``content_sha256`` is the SHA-256 of)
    The document without its ``content_sha256`` field, serialised as UTF-8 by
    ``json.dumps(doc, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)``.
    Numbers are written as Python writes them (``repr``: the shortest text that parses back to the
    same IEEE-754 double), so a load → dump cycle reproduces the canonical bytes exactly.

Training-data hash (``training_data.sha256``)
    SHA-256 of ``X`` as little-endian float64 in row-major order followed by ``y`` as
    little-endian float64, with ``X`` in the column order of ``inputs`` and in raw units
    (before any scaling).

Reading is strict: duplicate keys, ``NaN``/``Infinity`` and numbers that overflow a double are
rejected, and nothing but ``json`` parsing happens (no pickle, no ``eval``). Hostile text is refused
before the parser sees it or as it reads it: more than :data:`MAX_BYTES` bytes, arrays/objects
nested deeper than :data:`MAX_DEPTH`, more than :data:`MAX_ARRAYS` arrays, or a number written with
more than :data:`MAX_NUMBER_CHARS` characters (an integer
with more than :data:`MAX_INTEGER_DIGITS` digits).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from svrqp.exceptions import ProblemError
from svrqp.export.budget import MAX_INPUTS, MAX_PROBES, MAX_SUPPORT_VECTORS
from svrqp.table_checks import repeated

HASH_FIELD = "content_sha256"

#: Largest model file read (bytes): the largest model file svrqp.export.budget allows (10 000
#: support vectors of 20 inputs, ~5 MB) with room to
#: spare; parsing it takes about a second, not minutes.
MAX_BYTES = 16 * 2**20

#: Deepest nesting of arrays and objects; an svrqp.model/1 document needs 5.
MAX_DEPTH = 32

#: Most arrays in a model file: a row per support vector and probe point (svrqp.export.budget), a
#: precision-matrix row per input, and the document's few vectors.
MAX_ARRAYS = MAX_SUPPORT_VECTORS + MAX_PROBES + MAX_INPUTS + 64

#: Longest number text; Python's repr of a double needs at most 24 characters.
MAX_NUMBER_CHARS = 64

#: Most digits in an integer; the document's integers are counts and degrees.
MAX_INTEGER_DIGITS = 15

_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"')

DATA_HASH_DEFINITION = (
    "sha256(X as little-endian float64, row-major, columns in the order of 'inputs', raw units; "
    "then y as little-endian float64)"
)


def canonical_bytes(document: dict[str, Any]) -> bytes:
    """The canonical serialisation of ``document`` with its hash field left out."""
    content = {key: value for key, value in document.items() if key != HASH_FIELD}
    text = json.dumps(content, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False)
    try:
        return text.encode("utf-8")
    except UnicodeEncodeError as err:  # JSON's "\ud800" escape reads as a lone surrogate
        raise ProblemError(f"model file holds a string that is not valid Unicode ({err.reason}: "
                           f"{text[err.start:err.end]!a})") from None


def content_sha256(document: dict[str, Any]) -> str:
    """Hex SHA-256 of :func:`canonical_bytes`."""
    return hashlib.sha256(canonical_bytes(document)).hexdigest()


def data_sha256(X: ArrayLike, y: ArrayLike) -> str:
    """Hex SHA-256 of the training data, as defined in :data:`DATA_HASH_DEFINITION`."""
    X = np.ascontiguousarray(np.asarray(X, dtype="<f8"))
    y = np.ascontiguousarray(np.asarray(y, dtype="<f8").ravel())
    digest = hashlib.sha256(X.tobytes(order="C"))
    digest.update(y.tobytes())
    return digest.hexdigest()


def _reject_constant(name: str) -> float:
    raise ProblemError(f"model file holds the non-finite number {name}; JSON models hold finite "
                       f"numbers only")


def _finite_float(text: str) -> float:
    if len(text) > MAX_NUMBER_CHARS:
        raise ProblemError(f"model file holds a number written with {len(text)} characters "
                           f"(at most {MAX_NUMBER_CHARS}): {text[:20]}...")
    value = float(text)
    if not math.isfinite(value):
        raise ProblemError(f"model file holds the number {text}, which overflows a double")
    return value


def _bounded_int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INTEGER_DIGITS:
        raise ProblemError(f"model file holds an integer with {len(text.lstrip('-'))} digits "
                           f"(at most {MAX_INTEGER_DIGITS}): {text[:20]}...")
    return int(text)


def _structure(text: str) -> tuple[int, int]:
    """Deepest nesting of ``[``/``{`` and the number of arrays in JSON ``text`` (brackets inside
    strings not counted), by one vectorised pass over its bytes."""
    codes = np.frombuffer(_JSON_STRING.sub('""', text).encode("utf-8"), dtype=np.uint8)
    opening = codes == ord("[")
    step = (opening | (codes == ord("{"))).astype(np.int64) - np.isin(codes, (ord("]"), ord("}")))
    return int(np.cumsum(step).max(initial=0)), int(opening.sum())


def nesting_depth(text: str) -> int:
    """Deepest nesting of ``[``/``{`` in JSON ``text``, brackets inside strings not counted."""
    return _structure(text)[0]


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    duplicates = repeated(key for key, _ in pairs)
    if duplicates:
        raise ProblemError(f"model file repeats the key(s) {duplicates}; each key may appear once")
    return dict(pairs)


def parse_strict(text: str) -> Any:
    """Parse JSON text, rejecting duplicate keys,
    non-finite or over-long numbers and deep nesting."""
    depth, arrays = _structure(text)
    if depth > MAX_DEPTH:
        raise ProblemError(f"model file nests arrays/objects {depth} deep (at most {MAX_DEPTH})")
    # before parsing: a million probe rows are refused in a fraction of a second
    if arrays > MAX_ARRAYS:
        raise ProblemError(f"model file holds {arrays} arrays, more than the {MAX_ARRAYS} a model "
                           f"file may have "
                           "(one per support vector, probe point and input, and a few more)")
    try:
        return json.loads(text, parse_constant=_reject_constant, parse_float=_finite_float,
                          parse_int=_bounded_int, object_pairs_hook=_unique_keys)
    except json.JSONDecodeError as err:
        raise ProblemError(f"model file is not valid JSON: {err}") from None
