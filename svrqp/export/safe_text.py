"""User text that reaches generated files: comment-safe escaping and whitelisted names.

Input names, units and the model formula come from the document, which may have been edited by
anyone. Before any of it is written into a C comment (or a ``#`` line of the CSV table) it passes
through :func:`comment_text`, which makes it inert there:

* ``\\`` becomes ``\\\\`` (so the escaping below is unambiguous);
* control characters (line breaks included) become ``\\n``, ``\\t``, ``\\r`` or ``\\xHH`` /
  ``\\uHHHH`` text, so a value stays on its one comment line;
* ``*/`` and ``/*`` become ``*\\/`` and ``/\\*`` (a C block comment cannot be closed or nested);
* ``??`` becomes ``?\\?`` (no C trigraph, e.g. ``??/``, can form).

File and macro names written into the C source are never escaped but checked against a
whitelist (:func:`c_file_name`, :func:`c_macro_name`): they are code, not comments.
"""

from __future__ import annotations

import re
import unicodedata

from svrqp.exceptions import ProblemError

_NAMED = {"\n": "\\n", "\t": "\\t", "\r": "\\r"}
_FILE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}")
_MACRO_NAME = re.compile(r"[A-Z_][A-Z0-9_]{0,63}")


def _escape_char(ch: str) -> str:
    if ch == "\\":
        return "\\\\"
    if ch in _NAMED:
        return _NAMED[ch]
    # Cc: C0/C1 controls; Zl/Zp: line and paragraph separators; Cf: invisible format characters.
    if unicodedata.category(ch) in ("Cc", "Zl", "Zp", "Cf", "Cs", "Co", "Cn"):
        return f"\\x{ord(ch):02x}" if ord(ch) < 0x100 else f"\\u{ord(ch):04x}"
    return ch


def comment_text(text: str) -> str:
    """``text`` escaped so that it is inert inside a C block comment or a ``#`` comment line."""
    escaped = "".join(_escape_char(ch) for ch in str(text))
    return escaped.replace("*/", "*\\/").replace("/*", "/\\*").replace("??", "?\\?")


def c_file_name(name: str) -> str:
    """``name`` unchanged when it is a plain file name fit for ``#include "..."``.

    Raises
    ------
    ProblemError
        When it holds anything but ASCII letters, digits, ``_``, ``.`` and ``-``.
    """
    if not _FILE_NAME.fullmatch(name):
        raise ProblemError(f"C file name {name!r}: use ASCII letters, digits, '_', '.' and '-' "
                           "only (it is written into an #include line)")
    return name


def c_macro_name(name: str) -> str:
    """``name`` unchanged when it is a valid upper-case C macro name (``SVRQP_MODEL_H``)."""
    if not _MACRO_NAME.fullmatch(name):
        raise ProblemError(f"C macro name {name!r}: use upper-case ASCII letters, digits and '_', "
                           "not starting with a digit")
    return name
