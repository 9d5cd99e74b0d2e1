"""Record a full demo's reproduction rows and generate the table of ``docs/reproduction.md``.

Run in the repository root after a full ``svrqp demo`` (not ``--quick``)::

    python -m svrqp.demo.record demo-output/results.json

It writes the rows to :data:`RECORDED` and replaces the block between the markers of
:data:`DOCS_PAGE` with the table of those rows (:func:`docs_block`); the test suite checks that
the page holds exactly that block.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from svrqp.demo.vocabulary import markdown_table, rule_text
from svrqp.exceptions import ProblemError

#: The recorded rows of the last full ``svrqp demo`` (not ``--quick``), from which the table of
#: ``docs/reproduction.md`` is generated; both are rewritten by :func:`main`.
RECORDED = Path("benchmarks") / "results" / "demo_reproduction.json"
DOCS_PAGE = Path("docs") / "reproduction.md"
TABLE_START, TABLE_END = "<!-- reproduction-table: start -->", "<!-- reproduction-table: end -->"


def docs_block(rows: list[dict[str, Any]]) -> str:
    """The generated block of ``docs/reproduction.md``: the table and the rule, between markers."""
    return f"{TABLE_START}\n{markdown_table(rows)}\n{rule_text()}\n{TABLE_END}"


def with_docs_block(page: str, rows: list[dict[str, Any]]) -> str:
    """``page`` with its generated block replaced by :func:`docs_block` of ``rows``."""
    if TABLE_START not in page or TABLE_END not in page:
        raise ProblemError(f"the page has no {TABLE_START!r} … {TABLE_END!r} block")
    head, rest = page.split(TABLE_START, 1)
    return head + docs_block(rows) + rest.split(TABLE_END, 1)[1]


def main(argv: list[str] | None = None) -> int:
    """Record a full demo's rows and regenerate the docs table from them (run in the repo root).

    ``python -m svrqp.demo.record demo-output/results.json``
    """
    parser = argparse.ArgumentParser(description=main.__doc__.splitlines()[0])
    parser.add_argument("results", type=Path, help="results.json of a full svrqp demo")
    args = parser.parse_args(argv)
    results = json.loads(args.results.read_text(encoding="utf-8"))
    if results.get("quick"):
        raise ProblemError(f"{args.results} is a --quick run; record a full svrqp demo")
    rows = results["reproduction"]
    RECORDED.write_text(json.dumps(rows, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    DOCS_PAGE.write_text(with_docs_block(DOCS_PAGE.read_text(encoding="utf-8"), rows),
                         encoding="utf-8")
    print(f"wrote {RECORDED} and the table of {DOCS_PAGE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
