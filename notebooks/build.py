"""Build the paired ``.ipynb`` of each notebook from its jupytext source, with executed outputs.

The source of every notebook is ``notebooks/NAME.py`` (jupytext percent format); the ``.ipynb``
next to it is generated, executed and committed with its outputs so that a reader (and the
documentation site) sees the results without running anything. Cell ids are ``cell-00``,
``cell-01``, … in order, and no execution timestamps are stored, so rebuilding an unchanged
notebook gives the same file.

    python notebooks/build.py            # every notebook
    python notebooks/build.py 01 03      # the notebooks whose names start with 01 or 03
    python notebooks/build.py --check    # fail if an .ipynb no longer matches its source

``--check`` does not execute anything; ``tests/test_notebooks.py`` runs the same check.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import jupytext
import nbformat
from nbclient import NotebookClient

HERE = Path(__file__).resolve().parent
TIMEOUT_S = 600


def sources() -> list[Path]:
    """The jupytext sources: every ``NN_*.py`` of this folder."""
    return sorted(path for path in HERE.glob("[0-9][0-9]_*.py"))


def cell_id(index: int) -> str:
    """The stable id of the cell at ``index``."""
    return f"cell-{index:02d}"


def from_source(source: Path) -> nbformat.NotebookNode:
    """The notebook that ``source`` describes, without outputs, with stable cell ids."""
    notebook = jupytext.read(source)
    for index, cell in enumerate(notebook.cells):
        cell["id"] = cell_id(index)
    return notebook


def drift(source: Path) -> list[str]:
    """Differences between ``source`` and its paired ``.ipynb`` (empty when they match)."""
    paired = source.with_suffix(".ipynb")
    if not paired.exists():
        return [f"{paired.name} is missing"]
    expected = from_source(source).cells
    actual = nbformat.read(paired, as_version=4).cells
    problems = []
    if len(expected) != len(actual):
        problems.append(f"{paired.name}: {len(actual)} cells, its source has {len(expected)}")
    for index, (want, have) in enumerate(zip(expected, actual, strict=False)):
        if (want.cell_type, want.source.strip()) != (have.cell_type, have.source.strip()):
            problems.append(f"{paired.name}: cell {index} differs from {source.name}")
        if have.get("id") != cell_id(index):
            problems.append(f"{paired.name}: cell {index} has id {have.get('id')!r}, expected {cell_id(index)!r}")
    return problems


def coalesced(outputs: list) -> list:
    """Consecutive stream outputs of one stream joined: how a kernel chunks its output is timing."""
    joined = []
    for output in outputs:
        previous = joined[-1] if joined else None
        if (output.output_type == "stream" and previous is not None and previous.output_type == "stream"
                and previous.name == output.name):
            previous.text += output.text
        else:
            joined.append(output)
    return joined


def build(source: Path) -> Path:
    """Execute the notebook of ``source`` (working directory: this folder) and write its ``.ipynb``."""
    notebook = from_source(source)
    client = NotebookClient(notebook, timeout=TIMEOUT_S, kernel_name="python3", record_timing=False,
                            resources={"metadata": {"path": str(HERE)}})
    client.execute()
    for cell in notebook.cells:
        cell.get("metadata", {}).pop("execution", None)
        if cell.cell_type == "code":
            cell.outputs = coalesced(cell.outputs)
    notebook.metadata.pop("widgets", None)
    target = source.with_suffix(".ipynb")
    jupytext.write(notebook, target, fmt="ipynb")
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="name prefixes of the notebooks to build (default: all)")
    parser.add_argument("--check", action="store_true", help="compare with the sources, execute nothing")
    args = parser.parse_args(argv)
    chosen = [path for path in sources() if not args.names or any(path.name.startswith(n) for n in args.names)]
    if not chosen:
        print(f"no notebook source matches {args.names}", file=sys.stderr)
        return 1
    if args.check:
        problems = [problem for path in chosen for problem in drift(path)]
        print("\n".join(problems) or f"{len(chosen)} notebooks match their sources")
        return 1 if problems else 0
    for path in chosen:
        print(f"built {build(path).relative_to(HERE.parent)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
