"""Tampered model files: every one must end in a failed ``verify`` report or the library's own error.

Each case takes a valid ``svrqp.model/1`` file (an RBF ε-SVR on standardised inputs, a linear
model, a Legendre polynomial, a guarded linear model with interval and domain), tampers with it in one of :data:`TAMPERS` ways drawn from a seeded
generator, writes it and runs ``verify``, then ``read_document`` and the C writer. The outcome:

* ``documented error`` — ``verify`` reports a failed check, or svrqp raises its own ``SvrqpError``;
* ``right answer`` — the file verifies, and the model it holds predicts what the original predicts
  (within the original's probe tolerance, at the probes and at the support vectors; for a guarded
  model also the interval and the out-of-domain flags), and no text
  of the file reaches the generated C outside a comment;
* ``silent wrong`` — the file verifies but its model predicts otherwise, or its text became code;
* ``crash`` — any other exception (a traceback).

Forging is out of scope: whoever edits a file can recompute both the probe predictions and the
hash, and the file is then self-consistent (the hash proves integrity, not authorship; see
``docs/export.md``). Tampering that re-hashes *without* recomputing the predictions is in scope.

``cases(rng, n)`` returns ``n`` zero-argument :class:`Case` callables (each with a short
``label``) for a shared adversarial benchmark; run alone, this script prints the outcome table::

    python benchmarks/adversarial_documents.py [n_cases] [seed]
"""

from __future__ import annotations

import copy
import json
import re
import sys
import tempfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from svrqp import EpsilonSVR, Guarded
from svrqp.exceptions import SvrqpError
from svrqp.export import build_document, content_sha256, evaluate, read_document, verify
from svrqp.export.c_source import c_source
from svrqp.export.guarded import predict_guarded
from svrqp.estimators import LinearLS, PolynomialLS

OUTCOMES = ("documented error", "right answer", "silent wrong", "crash")

#: Strings that try to leave a C comment, a CSV comment line or a JSON string.
HOSTILE_TEXT = ('*/ int injected = 1; /*', '*/\n#include <stdlib.h>\n/*', '??/\nint x;', '\\', '"', '\u2028',
                '\x00', '%s%n', '\ud800', '*' * 40 + '/', '// */', 'é°μ' * 50)


@dataclass(frozen=True)
class Case:
    """One tampered file: ``case()`` runs it and returns one of :data:`OUTCOMES`."""

    label: str
    run: Callable[[], str]

    def __call__(self) -> str:
        return self.run()


#: The names of :func:`base_documents` (known without building them).
BASES = ("svr", "mlr", "poly", "guarded")


@cache
def base_documents() -> dict[str, dict[str, Any]]:
    """Four valid documents, each of another kind, fitted on seeded synthetic thermal data."""
    rng = np.random.default_rng(20261125)
    X = pd.DataFrame({"T7_C": rng.uniform(28.0, 40.0, 40), "T9_C": rng.uniform(27.0, 33.0, 40)})
    y = pd.Series(3.0 * (X["T7_C"] - 34.0) - np.sin(X["T9_C"]) + rng.normal(0, 0.1, 40), name="error_um")
    svr = make_pipeline(StandardScaler(), EpsilonSVR(C=100.0, epsilon=0.1, gamma=0.5)).fit(X, y)
    x_mm = pd.DataFrame({"x_mm": np.linspace(0.0, 550.0, 23)})
    dx = pd.Series(1e-6 * (x_mm["x_mm"] - 275.0) ** 2 + rng.normal(0, 0.01, 23), name="delta_x_um")
    guarded = Guarded(LinearLS(), coverage=0.8).fit(X, y, groups=np.arange(40) // 8)
    return {"svr": build_document(svr, X, y), "mlr": build_document(LinearLS().fit(X, y), X, y),
            "poly": build_document(PolynomialLS(degree=3).fit(x_mm, dx), x_mm, dx),
            "guarded": build_document(guarded, X, y)}


def leaves(node: Any, path: tuple = ()) -> list[tuple]:
    """Paths of every leaf (number, string, bool, null) of a JSON document."""
    if isinstance(node, dict):
        return [p for key, value in node.items() for p in leaves(value, (*path, key))]
    if isinstance(node, list):
        return [p for i, value in enumerate(node) for p in leaves(value, (*path, i))]
    return [path]


def _get(document: Any, path: tuple) -> Any:
    for key in path:
        document = document[key]
    return document


def _set(document: Any, path: tuple, value: Any) -> None:
    _get(document, path[:-1])[path[-1]] = value


def _pick(rng: np.random.Generator, items: list) -> Any:
    return items[int(rng.integers(len(items)))]


def _numbers(document: dict) -> list[tuple]:
    return [p for p in leaves(document) if type(_get(document, p)) in (int, float)]


def _strings(document: dict) -> list[tuple]:
    return [p for p in leaves(document) if isinstance(_get(document, p), str)]


def _text(document: dict, rehash: bool) -> str:
    if rehash:
        try:
            document["content_sha256"] = content_sha256(document)
        except SvrqpError:  # a lone surrogate cannot be hashed: the file keeps the old hash
            pass
    return json.dumps(document, ensure_ascii=True)


def _edit_number(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    path = _pick(rng, _numbers(document))
    value = _get(document, path)
    choices = [value * (1 + 10 ** rng.uniform(-12, 1)), -value, 0, 1e308, 5e-324, value + 1, 10 ** int(rng.integers(1, 15))]
    _set(document, path, _pick(rng, choices))
    rehash = bool(rng.integers(2))
    return f"number edit{' + rehash' if rehash else ''}", _text(document, rehash)


def _widen_tolerance(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    document["probes"]["tolerance"] = float(10 ** rng.uniform(-8, 300))
    coefficients = document["model"].get("dual_coef") or document["model"]["coef"]
    coefficients[int(rng.integers(len(coefficients)))] *= 1 + 10 ** rng.uniform(-6, 0)
    return "tolerance widened + coefficient edit + rehash", _text(document, True)


def _delete_key(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    path = _pick(rng, [p for p in leaves(document) if isinstance(p[-1], str)])
    del _get(document, path[:-1])[path[-1]]
    return "key deleted + rehash", _text(document, True)


def _add_key(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    parent = _pick(rng, [(), ("model",), ("probes",), ("solver",), ("inputs", 0)])
    _get(document, parent)["__class__"] = _pick(rng, ["os.system", 1, None, {"__reduce__": []}])
    return "key added + rehash", _text(document, True)


def _retype(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    path = _pick(rng, leaves(document))
    _set(document, path, _pick(rng, ["1", [], {}, None, True, [1.0, 2.0], -1]))
    return "leaf retyped + rehash", _text(document, True)


def _hostile_string(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    path = _pick(rng, _strings(document))
    _set(document, path, str(_get(document, path)) + _pick(rng, list(HOSTILE_TEXT)))
    return "hostile string + rehash", _text(document, True)


def _bad_date(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    year, month, day, hour, minute, second = rng.integers(0, 100, 6)
    document["created_utc"] = f"20{year:02d}-{month:02d}-{day:02d}T{hour:02d}:{minute:02d}:{second:02d}Z"
    return "random created_utc + rehash", _text(document, True)


def _raw_edit(rng: np.random.Generator, text: str, make: Callable[[np.random.Generator], str], label: str,
              ) -> tuple[str, str]:
    spans = [m.span() for m in re.finditer(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?", text)]
    start, end = _pick(rng, spans)
    return label, text[:start] + make(rng) + text[end:]


def _deep_nesting(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    def nest(rng: np.random.Generator) -> str:
        depth = int(10 ** rng.uniform(1, 5))
        return "[" * depth + "]" * depth
    return _raw_edit(rng, _text(document, False), nest, "deep nesting")


def _long_number(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    def number(rng: np.random.Generator) -> str:
        digits = "".join(map(str, rng.integers(0, 10, int(rng.integers(16, 2000)))))
        return _pick(rng, ["1" + digits, "0." + digits, "1" + digits + "e-5", "1e" + digits[:4]])
    return _raw_edit(rng, _text(document, False), number, "long number")


def _flip_byte(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    text = _text(document, False)
    i = int(rng.integers(len(text)))
    return "byte changed", text[:i] + _pick(rng, list('0-.e"[]{},: x\\\x00é')) + text[i + 1:]


def _truncate(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    text = _text(document, False)
    return "truncated", text[:int(rng.integers(len(text)))]


def _duplicate_key(rng: np.random.Generator, document: dict) -> tuple[str, str]:
    text = _text(document, False)
    return "duplicate key", text.replace('"intercept": ', '"intercept": 0.0, "intercept": ', 1) \
        if '"intercept": ' in text else text.replace('"coef": ', '"coef": [], "coef": ', 1)


#: Every way a file is tampered with: rng, a copy of a valid document → (label, file text).
TAMPERS: dict[str, Callable[[np.random.Generator, dict], tuple[str, str]]] = {
    "number": _edit_number, "tolerance": _widen_tolerance, "delete": _delete_key, "add": _add_key,
    "retype": _retype, "string": _hostile_string, "date": _bad_date, "nesting": _deep_nesting,
    "long_number": _long_number, "byte": _flip_byte, "truncate": _truncate, "duplicate": _duplicate_key,
}

_STRING_PLACEHOLDER = "x"


def _code(document: dict) -> str:
    return re.sub(r"/\*.*?\*/", "", c_source(document), flags=re.DOTALL)


def _text_reaches_code(document: dict) -> bool:
    """True when the C differs outside comments once every free-text string is a placeholder."""
    plain = copy.deepcopy(document)
    for path in _strings(plain):
        if path[0] in ("inputs", "target") or path in (("model", "formula"), ("library", "version")):
            _set(plain, path, _STRING_PLACEHOLDER)
    return _code(plain) != _code(document)


def _same_model(original: dict, loaded: dict) -> bool:
    """The loaded model predicts the original's values at its probes and support vectors."""
    X = np.asarray(original["probes"]["X"], dtype=float)
    if "support_vectors" in original["model"]:
        U = np.asarray(original["model"]["support_vectors"], dtype=float)
        scaling = original["scaling"]
        X = np.vstack([X, U if scaling is None else U * np.asarray(scaling["scale"]) + np.asarray(scaling["mean"])])
    with np.errstate(all="ignore"):
        if "interval" not in original:
            deviation = np.abs(evaluate.predict(loaded, X) - evaluate.predict(original, X))
            return bool(np.all(deviation <= original["probes"]["tolerance"]))
        if "interval" not in loaded:
            return False
        *values, flags = predict_guarded(loaded, X)
        *reference, reference_flags = predict_guarded(original, X)
    deviation = max(float(np.max(np.abs(a - b))) for a, b in zip(values, reference, strict=True))
    return deviation <= original["probes"]["tolerance"] and np.array_equal(flags, reference_flags)


def outcome(original: dict, text: str) -> str:
    """Write ``text``, verify, load and generate C from it; classify as one of :data:`OUTCOMES`."""
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "model.json"
        path.write_bytes(text.encode("utf-8", errors="surrogatepass"))
        try:
            if not verify(path).ok:
                return "documented error"
            loaded = read_document(path)
            if not _same_model(original, loaded) or _text_reaches_code(loaded):
                return "silent wrong"
            return "right answer"
        except SvrqpError:
            return "documented error"
        except Exception:  # noqa: BLE001  (the point: any other exception is counted as a crash)
            return "crash"


def tampered(rng: np.random.Generator, base: str, tamper: str) -> tuple[str, str]:
    """``(label, file text)`` of document ``base`` tampered with by ``TAMPERS[tamper]``."""
    label, text = TAMPERS[tamper](rng, copy.deepcopy(base_documents()[base]))
    return f"{base}: {label}", text


def _case(seed: int, base: str, tamper: str) -> Case:
    label, text = tampered(np.random.default_rng(seed), base, tamper)
    return Case(label, lambda: outcome(base_documents()[base], text))


def cases(rng: np.random.Generator, n: int) -> list[Case]:
    """``n`` tampered-file cases drawn from ``rng`` (document, tampering and its details)."""
    bases, tampers = list(BASES), list(TAMPERS)
    return [_case(int(rng.integers(2**32)), _pick(rng, bases), _pick(rng, tampers)) for _ in range(n)]


def table(results: list[tuple[str, str]]) -> str:
    """Markdown table: per tampering, how many cases ended in each outcome."""
    kinds = sorted({label.split(": ", 1)[1] for label, _ in results})
    lines = ["| tampering | tried | " + " | ".join(OUTCOMES) + " |", "|---|---:|" + "---:|" * len(OUTCOMES)]
    for kind in [*kinds, None]:
        counts = Counter(result for label, result in results if kind is None or label.endswith(kind))
        name = "**all**" if kind is None else kind
        lines.append(f"| {name} | {sum(counts.values())} | " + " | ".join(str(counts[o]) for o in OUTCOMES) + " |")
    return "\n".join(lines)


def main(n: int = 2000, seed: int = 0) -> None:
    results = [(case.label, case()) for case in cases(np.random.default_rng(seed), n)]
    print(f"{n} tampered model files, seed {seed}\n")
    print(table(results))
    failures = [(label, result) for label, result in results if result in ("silent wrong", "crash")]
    for label, result in failures[:20]:
        print(f"{result}: {label}")


if __name__ == "__main__":
    main(*(int(arg) for arg in sys.argv[1:3]))
