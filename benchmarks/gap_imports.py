"""How many import edges join the modules of ``svrqp/gap`` (issue #35's measure of its coupling).

An edge is one (importing module, imported module) pair inside the package, read from the source
with :mod:`ast` (nothing is imported): ``from svrqp.gap.x import ...`` or a relative import, at
module level or inside a function. The package's own ``__init__`` counts like any module; the
count without it is printed too (issue #35 counted 109 before the reorganisation, which is this
count without ``svrqp/gap/__init__.py``: 112 with it; 82 after the sub-packages, and 72, 76 with
it, once the words read records instead of computing and no step passed through what another
already held; 71, 75 with it, once the ranking took ``RISE`` from ``svrqp.gap.data`` too).

Run: ``python benchmarks/gap_imports.py [ROOT]`` (ROOT: a checkout, by default this one).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

PACKAGE = "svrqp.gap"


def module_name(path: Path, root: Path) -> str:
    """``svrqp/gap/transfer/linear.py`` → ``svrqp.gap.transfer.linear``
    (a package by its ``__init__``)."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported(node: ast.ImportFrom | ast.Import, module: str, is_package: bool) -> list[str]:
    """The dotted modules an import statement names (a relative one resolved against ``module``)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if not node.level:
        return [node.module or ""]
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return [".".join(base + ([node.module] if node.module else []))]


def edges(root: Path) -> set[tuple[str, str]]:
    """Every (importer, imported) pair of modules inside :data:`PACKAGE` under ``root``."""
    found = set()
    for path in sorted((root / "svrqp" / "gap").rglob("*.py")):
        module = module_name(path, root)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                for target in imported(node, module, path.name == "__init__.py"):
                    if (target == PACKAGE or target.startswith(PACKAGE + ".")) and target != module:
                        found.add((module, target))
    return found


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    root = Path(argv[0]) if argv else Path(__file__).resolve().parents[1]
    pairs = edges(root)
    modules = {module_name(p, root) for p in (root / "svrqp" / "gap").rglob("*.py")}
    without_init = {(a, b) for a, b in pairs if a != PACKAGE}
    print(f"{len(modules)} modules; {len(pairs)} import edges "
          f"({len(without_init)} without {PACKAGE}'s __init__)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
