r"""Row filters for ``--train``: a small query language that selects rows and can do nothing else.

A filter is a boolean expression over the columns of a table, with the syntax of a pandas query
restricted to an explicit allow-list:

* column names (``T7_C``), or any name in backticks (```T7 [°C]```); a name denotes the column
  spelt with exactly the characters typed (never a Unicode-normalised form of them: ``ｔ`` is not
  ``t``), and backticks inside a string literal are part of the string;
* literals: numbers, strings, ``True``/``False``/``None``; a unary minus on a number or a column;
* comparisons ``== != < <= > >=``, chained (``20 < T7_C <= 30``);
* ``in`` / ``not in`` a list or tuple of literals (``batch in ['x1', 'x2']``);
* ``and``, ``or``, ``not`` (and pandas' spellings ``&``, ``|``, ``~``), parentheses.

Anything else — ``@`` (local variables), attributes, calls, subscripts, arithmetic, names
starting with ``__``, lambdas, f-strings — is refused with a :class:`QueryError` naming the
forbidden token, before anything is evaluated. The expression is parsed with :mod:`ast` and
evaluated by walking the tree with pandas boolean masks; nothing is handed to ``eval``,
``DataFrame.query`` or ``DataFrame.eval``.

>>> import pandas as pd
>>> table = pd.DataFrame({"batch": ["x1", "x2", "x1"], "T7_C": [25.0, 31.0, 35.0]})
>>> select_rows(table, "batch == 'x1' and T7_C > 30").tolist()
[False, False, True]
"""

from __future__ import annotations

import ast
import operator
from typing import Any

import numpy as np
import pandas as pd

from svrqp.exceptions import ProblemError

#: Longest filter accepted (characters): a selection, not a program.
MAX_QUERY_LENGTH = 2000

_COMPARE = {ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le,
            ast.Gt: operator.gt, ast.GtE: operator.ge}
_MEMBERSHIP = (ast.In, ast.NotIn)

#: Words shown for the constructs the language refuses (node type -> what the user wrote).
_FORBIDDEN = {
    ast.Attribute: "attribute access '.'", ast.Call: "function call '(...)'",
    ast.Subscript: "subscript '[...]'",
    ast.Lambda: "'lambda'", ast.JoinedStr: "f-string", ast.FormattedValue: "f-string",
    ast.IfExp: "'if ... else'", ast.NamedExpr: "':='", ast.ListComp: "comprehension",
    ast.SetComp: "comprehension", ast.DictComp: "comprehension", ast.GeneratorExp: "comprehension",
    ast.Dict: "dict literal", ast.Set: "set literal", ast.Starred: "'*'", ast.Await: "'await'",
    ast.Yield: "'yield'", ast.YieldFrom: "'yield'", ast.Slice: "slice",
}
_OPERATOR_SYMBOLS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.FloorDiv: "//",
                     ast.Mod: "%",
                     ast.Pow: "**", ast.MatMult: "@", ast.LShift: "<<", ast.RShift: ">>",
                     ast.BitXor: "^", ast.Is: "is", ast.IsNot: "is not"}


class QueryError(ProblemError):
    """A ``--train`` filter is malformed or uses a construct outside the filter language."""


def _string_end(query: str, i: int) -> int:
    """Index just past the string literal opening at ``query[i]`` (one of ``'`` ``"``, single or
    triple quoted); backslash escapes are skipped. An unterminated literal runs to the end (the
    parser then reports it)."""
    delimiter = query[i] * 3 if query.startswith(query[i] * 3, i) else query[i]
    j = i + len(delimiter)
    while j < len(query):
        if query[j] == "\\":
            j += 2
        elif query.startswith(delimiter, j):
            return j + len(delimiter)
        else:
            j += 1
    return len(query)


def _placeholder_prefix(query: str) -> str:
    """A prefix for the backtick placeholders that occurs nowhere in ``query``, so a placeholder can
    never be mistaken for a column the filter names directly."""
    prefix = "svrqp_column_"
    while prefix in query:
        prefix = "svrqp_" + prefix
    return prefix


def _backticks_to_names(query: str) -> tuple[str, dict[str, str]]:
    """Replace each ```name``` outside string literals by a placeholder identifier that occurs
    nowhere else in the filter; string literals (triple-quoted
    ones included) are copied untouched; refuse ``@``."""
    out: list[str] = []
    names: dict[str, str] = {}
    prefix = _placeholder_prefix(query)
    i = 0
    while i < len(query):
        char = query[i]
        if char in "'\"":
            end = _string_end(query, i)
            out.append(query[i:end])
            i = end
            continue
        if char == "@":
            raise QueryError(f"forbidden token '@' at position {i} in {query!r}: a filter refers "
                             "to columns only, not to variables")
        if char == "`":
            end = query.find("`", i + 1)
            if end < 0:
                raise QueryError(f"unclosed backtick at position {i} in {query!r}")
            placeholder = f"{prefix}{len(names)}"
            names[placeholder] = query[i + 1:end]
            out.append(f" {placeholder} ")
            i = end
        else:
            out.append(char)
        i += 1
    return "".join(out), names


def _resolve_names(tree: ast.Expression, source: str, names: dict[str, str]) -> None:
    """Set each name of ``tree`` to the column it denotes, read from the filter's own text.

    Python's parser NFKC-normalises identifiers (full-width ``ｔ`` becomes ``t``), which would
    silently select another column; the exact characters the user typed are taken from the source
    instead, and backtick placeholders are replaced by the names they stand for.
    """
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            typed = ast.get_source_segment(source, node) or node.id
            node.id = names.get(typed, typed)


def _describe(node: ast.AST) -> str:
    if isinstance(node, ast.BinOp | ast.UnaryOp | ast.BoolOp):
        symbol = _OPERATOR_SYMBOLS.get(type(node.op))
        return f"operator '{symbol}'" if symbol else type(node.op).__name__
    return _FORBIDDEN.get(type(node), type(node).__name__)


def _literal(node: ast.AST) -> bool:
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
        return isinstance(node.operand, ast.Constant) and isinstance(node.operand.value,
                                                                     int | float)
    return isinstance(node, ast.Constant) and isinstance(node.value,
                                                         int | float | str | bool | type(None))


def _check(node: ast.AST, query: str) -> None:
    """Raise :class:`QueryError` unless every node of the tree is in the allow-list."""
    def refuse(what: str) -> None:
        raise QueryError(f"forbidden {what} in filter {query!r}: a filter allows column names, "
                         "literals, comparisons, in / not in a list of literals, and / or / not")

    if isinstance(node, ast.Expression):
        _check(node.body, query)
    elif isinstance(node, ast.BoolOp):
        for value in node.values:
            _check(value, query)
    elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitAnd | ast.BitOr):
        _check(node.left, query)
        _check(node.right, query)
    elif isinstance(node, ast.UnaryOp) and isinstance(node.op,
                                                      ast.Not | ast.Invert | ast.USub | ast.UAdd):
        _check(node.operand, query)
    elif isinstance(node, ast.Compare):
        _check(node.left, query)
        for op, comparator in zip(node.ops, node.comparators, strict=False):
            if isinstance(op, _MEMBERSHIP):
                if len(node.ops) > 1:
                    refuse("chain with 'in' (put each membership test in its own parentheses)")
                if not (isinstance(comparator,
                                   ast.List | ast.Tuple) and all(map(_literal, comparator.elts))):
                    refuse("right-hand side of 'in' (give a list of literals, e.g. ['x1', 'x2'])")
            elif type(op) in _COMPARE:
                _check(comparator, query)
            else:
                refuse(f"comparison '{_OPERATOR_SYMBOLS.get(type(op), type(op).__name__)}'")
    elif isinstance(node, ast.Name):
        if node.id.startswith("__"):
            refuse(f"name {node.id!r} (names starting with '__')")
    elif isinstance(node, ast.Constant):
        if not _literal(node):
            refuse(f"literal {node.value!r}")
    else:
        refuse(_describe(node))


def parse(query: str) -> tuple[ast.Expression, dict[str, str]]:
    """Parse and check a filter; returns its tree and the backticked names it uses.

    Raises :class:`QueryError` for a malformed filter or one outside the language.
    """
    if not isinstance(query, str):
        raise QueryError(f"a filter must be a string, got {type(query).__name__}")
    if len(query) > MAX_QUERY_LENGTH:
        raise QueryError(f"filter of {len(query)} characters: at most {MAX_QUERY_LENGTH} are "
                         f"accepted")
    source, names = _backticks_to_names(query)
    source = source.strip()
    try:
        tree = ast.parse(source, mode="eval")
    except SyntaxError as err:
        raise QueryError(f"cannot evaluate query {query!r}: {err.msg}") from None
    except (ValueError, RecursionError, MemoryError) as err:  # NUL bytes, absurd nesting
        raise QueryError(f"cannot evaluate query {query!r}: {type(err).__name__}") from None
    try:
        _check(tree, query)
    except RecursionError:
        raise QueryError(f"filter nested too deeply: {query[:80]!r}...") from None
    _resolve_names(tree, source, names)
    return tree, names


def _evaluate(node: ast.AST, table: pd.DataFrame, names: dict[str, str], query: str) -> Any:
    if isinstance(node, ast.Expression):
        return _evaluate(node.body, table, names, query)
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.Name):
        column = node.id  # the exact name (see _resolve_names)
        if column not in table.columns:
            raise QueryError(f"filter {query!r}: unknown column {column!r}; columns: "
                             f"{list(map(str, table.columns))}")
        return table[column]
    if isinstance(node, ast.UnaryOp):
        operand = _evaluate(node.operand, table, names, query)
        if isinstance(node.op, ast.Not | ast.Invert):
            return _negated(_mask(operand, query))
        return -operand if isinstance(node.op, ast.USub) else +operand
    if isinstance(node, ast.BoolOp | ast.BinOp):
        values = node.values if isinstance(node, ast.BoolOp) else [node.left, node.right]
        masks = [_mask(_evaluate(value, table, names, query), query) for value in values]
        combine = operator.and_ if isinstance(node.op, ast.And | ast.BitAnd) else operator.or_
        result = masks[0]
        for mask in masks[1:]:
            result = combine(result, mask)
        return result
    if isinstance(node, ast.Compare):
        left = _evaluate(node.left, table, names, query)
        result: Any = True
        for op, comparator in zip(node.ops, node.comparators, strict=False):
            if isinstance(op, _MEMBERSHIP):  # never chained (see _check)
                choices = [ast.literal_eval(element) for element in comparator.elts]
                inside = left.isin(choices) if isinstance(left, pd.Series) else left in choices
                return inside if isinstance(op, ast.In) else _negated(_mask(inside, query))
            right = _evaluate(comparator, table, names, query)
            result = result & _mask(_COMPARE[type(op)](left, right), query)
            left = right
        return result
    # _check refused it already
    raise QueryError(f"forbidden {_describe(node)} in filter {query!r}")


def _negated(mask: Any) -> Any:
    return not mask if isinstance(mask, bool) else ~mask


def _mask(value: Any, query: str) -> Any:
    if isinstance(value, pd.Series):
        if not pd.api.types.is_bool_dtype(value.dtype):
            raise QueryError(f"query {query!r} must give True/False per row, got values of type "
                             f"{value.dtype}")
        # nullable booleans: a missing value counts as False
        return value.fillna(False).astype(bool)
    if isinstance(value, bool | np.bool_):
        return bool(value)
    raise QueryError(f"query {query!r} must give True/False per row, got {value!r}")


def select_rows(table: pd.DataFrame, query: str) -> pd.Series:
    """Boolean mask (aligned with ``table.index``) of the rows the filter ``query`` selects.

    Raises :class:`QueryError` (a :class:`~svrqp.exceptions.ProblemError`) when the filter is
    malformed, uses a construct outside the language, names an unknown column, compares values
    that cannot be compared, or does not give True/False per row.
    """
    tree, names = parse(query)
    try:
        with np.errstate(invalid="ignore"):
            result = _evaluate(tree, table, names, query)
    except QueryError:
        raise
    except RecursionError:
        raise QueryError(f"filter nested too deeply: {query[:80]!r}...") from None
    except (TypeError, ValueError) as err:  # e.g. a number compared with a text column
        raise QueryError(f"cannot evaluate query {query!r}: {err}") from None
    except OverflowError as err:  # an integer literal beyond float64 compared with a float column
        raise QueryError(
            f"cannot evaluate query {query!r}: a number is out of range ({err})"
        ) from None
    result = _mask(result, query)
    if isinstance(result, bool):
        return pd.Series(result, index=table.index)
    return result
