"""Turn the reStructuredText the package's docstrings use into Markdown for the site.

The docstrings follow numpydoc and write maths in reST (``.. math::`` blocks, ``:math:`` roles),
cross-references as Sphinx roles, links as ```text <url>`_`` and a few simple tables. Python
Markdown with ``pymdownx.arithmatex`` needs ``$...$`` / ``$$...$$``, code spans and pipe tables;
this module converts exactly those constructs and leaves everything else alone.
"""

from __future__ import annotations

import re

_MATH_ROLE = re.compile(r":math:`([^`]+)`")
_XREF_ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|data|attr|exc|obj|const):`(~?)([^`]+)`")
_LINK = re.compile(r"`([^`<]+?)\s*<(https?://[^>]+)>`__?")
_MATH_DIRECTIVE = re.compile(r"^(\s*)\.\. math::\s*(.*)$")
_TABLE_BORDER = re.compile(r"^\s*=+(?: +=+)+\s*$")


def _xref(match: re.Match) -> str:
    target = match[2]
    return f"`{target.rsplit('.', 1)[-1] if match[1] else target}`"


def _inline(text: str) -> str:
    text = _MATH_ROLE.sub(lambda m: f"${m[1].strip()}$", text)
    text = _XREF_ROLE.sub(_xref, text)
    return _LINK.sub(lambda m: f"[{m[1]}]({m[2]})", text)


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def _math_block(lines: list[str], start: int) -> tuple[list[str], int]:
    """The ``.. math::`` directive at ``lines[start]`` as ``$$`` blocks; returns (output, next index)."""
    match = _MATH_DIRECTIVE.match(lines[start])
    pad, body = match[1], [match[2]] if match[2].strip() else []
    end = start + 1
    while end < len(lines) and (not lines[end].strip() or _indent(lines[end]) > len(pad)):
        body.append(lines[end])
        end += 1
    while body and not body[-1].strip():
        body.pop()
    depth = min((_indent(line) for line in body if line.strip()), default=0)
    equations, current = [], []
    for line in body + [""]:
        if line.strip():
            current.append(pad + line[depth:].rstrip())
        elif current:
            equations.append(current)
            current = []
    output = [""]
    for equation in equations:  # blank-line separated equations are separate displays, as in Sphinx
        output += [pad + "$$", *equation, pad + "$$", ""]
    return output, end


def _table(lines: list[str], start: int) -> tuple[list[str], int] | None:
    """A reST simple table starting at the border ``lines[start]`` as a pipe table, or None."""
    border = lines[start]
    spans = [m.span() for m in re.finditer(r"=+", border)]
    borders = [start]
    end = start + 1
    while end < len(lines) and lines[end].strip():
        if _TABLE_BORDER.match(lines[end]):
            borders.append(end)
        end += 1
    if len(borders) < 2:
        return None
    rows: list[list[str]] = []
    header_rows = 0
    for index in range(start + 1, end):
        line = lines[index]
        if index in borders:
            if header_rows == 0 and index != borders[-1]:
                header_rows = len(rows)
            continue
        cells = [line[a: (spans[k + 1][0] if k + 1 < len(spans) else None)].strip() for k, (a, _) in enumerate(spans)]
        if rows and not cells[0]:  # continuation line: first column empty
            rows[-1] = [f"{old} {new}".strip() for old, new in zip(rows[-1], cells)]
        else:
            rows.append(cells)
    header_rows = header_rows or 1
    pad = " " * _indent(border)
    header = [" ".join(cells).strip() for cells in zip(*rows[:header_rows])]
    output = ["", pad + "| " + " | ".join(header) + " |", pad + "|" + "---|" * len(header)]
    output += [pad + "| " + " | ".join(_inline(cell) for cell in row) + " |" for row in rows[header_rows:]]
    return output + [""], end


def rst_to_markdown(text: str) -> str:
    """Convert the reST constructs of a docstring to Markdown (see the module docstring)."""
    lines = text.splitlines()
    output: list[str] = []
    prose: list[str] = []  # roles may wrap over lines: convert prose a paragraph run at a time

    def flush() -> None:
        if prose:
            output.extend(_inline("\n".join(prose)).split("\n"))
            prose.clear()

    index = 0
    while index < len(lines):
        line = lines[index]
        block = None
        if _MATH_DIRECTIVE.match(line):
            block = _math_block(lines, index)
        elif _TABLE_BORDER.match(line):
            block = _table(lines, index)
        if block is None:
            prose.append(line)
            index += 1
            continue
        flush()
        converted, index = block
        output += converted
    flush()
    return "\n".join(output)
