"""The package's shape: the layers of CONTRIBUTING, no import cycle, small modules, short functions.

Read from the source with :mod:`ast` (nothing is imported), so an import placed inside a
function counts like any other. The layers are read from the tree of CONTRIBUTING.md ("Where
things are"): each line naming top-level modules or packages (``name.py``, ``name/``) is one
layer, the lowest first, and a module may import only from its own layer or below. A package
counts as one unit whatever its inner structure (``svrqp/gap/...`` is ``gap``).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "svrqp"
CONTRIBUTING = PACKAGE.parent / "CONTRIBUTING.md"
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 80
MAX_PARAMETERS = 8


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(path): path for path in sorted(PACKAGE.rglob("*.py"))}
TREES = {name: ast.parse(path.read_text(encoding="utf-8")) for name, path in MODULES.items()}


def _resolve(dotted: str) -> str | None:
    """The svrqp module an import names (``svrqp.a.b.symbol`` -> ``svrqp.a.b``)."""
    while dotted and dotted not in MODULES:
        dotted = dotted.rpartition(".")[0]
    return dotted or None


def _imports(name: str) -> set[str]:
    """Every svrqp module ``name`` imports, at module level or inside functions."""
    is_package = MODULES[name].name == "__init__.py"
    found = set()
    for node in ast.walk(TREES[name]):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = name.split(".") if is_package else name.split(".")[:-1]
                base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
            targets = [f"{base}.{alias.name}" for alias in node.names]
        else:
            continue
        found |= {module for module in map(_resolve, targets) if module and module != name}
    return found


def _unit(module: str) -> str | None:
    """The top-level module or package of ``module`` (``svrqp.gap.x.y`` -> ``gap``; ``svrqp`` -> None)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def _layers(text: str) -> dict[str, int]:
    """Each top-level module or package in the ``svrqp/`` tree of ``text`` -> its layer (0 = lowest).

    A layer is a line indented by two spaces whose first words are names ending in ``.py`` or
    ``/``; the words after them, and lines indented further, describe them.
    """
    block = text.split("## Where things are", 1)[1].split("```text\n", 1)[1].split("```", 1)[0]
    lines = block.splitlines()
    layers: dict[str, int] = {}
    level = 0
    for line in lines[lines.index("svrqp/") + 1:]:
        if not line.startswith("  "):
            break  # the tree of svrqp/ ends where tests/, docs/ ... begin
        if line.startswith("   "):
            continue
        names = []
        for word in line.split():
            if not re.fullmatch(r"\w+(\.py|/)", word):
                break
            names.append(word.removesuffix("/").removesuffix(".py"))
        for name in names:
            assert name not in layers, f"CONTRIBUTING's tree names {name} twice"
            layers[name] = level
        level += bool(names)
    return layers


LAYERS = _layers(CONTRIBUTING.read_text(encoding="utf-8"))


def _layer_violations() -> list[str]:
    """Every import from a module to a top-level unit on a higher layer of CONTRIBUTING's tree."""
    found = []
    for name in MODULES:
        unit = _unit(name)
        if unit is None:  # svrqp/__init__.py: the package's face, above every layer
            continue
        for target in sorted(_imports(name)):
            other = _unit(target)
            if other is None or other == unit:
                if other is None:
                    found.append(f"{name} imports the package face svrqp")
                continue
            if LAYERS[other] > LAYERS[unit]:
                found.append(f"{name} (layer {LAYERS[unit]}, {unit}) imports {target} "
                             f"(layer {LAYERS[other]}, {other})")
    return found


def _cycles() -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    graph = {name: _imports(name) for name in MODULES}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    components = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for successor in graph[node]:
            if successor not in index:
                visit(successor)
                low[node] = min(low[node], low[successor])
            elif successor in stack:
                low[node] = min(low[node], index[successor])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for name in graph:
        if name not in index:
            visit(name)
    return components


def _exempt(name: str, function: ast.FunctionDef) -> bool:
    """Typer commands take one parameter per option; scikit-learn estimators one per hyper-parameter."""
    defaults = [*function.args.defaults, *function.args.kw_defaults]
    is_command = name.startswith("svrqp.cli.") and any(
        isinstance(d, ast.Call) and isinstance(d.func, ast.Attribute) and d.func.attr in ("Option", "Argument")
        for d in defaults)
    is_estimator_init = function.name == "__init__" and name.startswith(("svrqp.estimators.", "svrqp.guard.estimator"))
    return is_command or is_estimator_init


def _parameters(function: ast.FunctionDef) -> int:
    arguments = function.args
    names = [a.arg for a in (*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs)]
    names += [a.arg for a in (arguments.vararg, arguments.kwarg) if a is not None]
    return len([n for n in names if n not in ("self", "cls")])


def _body_lines(function: ast.FunctionDef) -> int:
    body = function.body
    has_docstring = isinstance(body[0], ast.Expr) and isinstance(getattr(body[0], "value", None), ast.Constant)
    first = body[1].lineno if has_docstring and len(body) > 1 else body[0].lineno
    return function.end_lineno - first + 1


def test_the_scan_sees_the_package_and_its_imports():
    assert "svrqp.estimators.kernel" in MODULES and "svrqp.solution" in MODULES
    assert "svrqp.solution" in _imports("svrqp.solvers.qp_backends")
    assert "svrqp.estimators" in _imports("svrqp.registry")  # imported on first use, inside a function


def test_the_layers_are_read_from_contributing_and_would_catch_an_upward_import():
    assert LAYERS["exceptions"] == 0
    assert LAYERS["linalg"] < LAYERS["formulations"] < LAYERS["solvers"]
    assert LAYERS["description"] < LAYERS["estimators"] < LAYERS["registry"] < LAYERS["export"]
    tree = ("## Where things are\n```text\nsvrqp/\n  a.py  b/     words\n                 more words\n"
            "  c/\ntests/\n```")
    assert _layers(tree) == {"a": 0, "b": 0, "c": 1}


def test_contributing_tree_names_every_top_level_module_and_package_and_nothing_else():
    units = {_unit(name) for name in MODULES} - {None}
    assert sorted(units - set(LAYERS)) == [], "add these to the tree of CONTRIBUTING.md, on their layer"
    assert sorted(set(LAYERS) - units) == [], "the tree of CONTRIBUTING.md names these, which do not exist"


def test_every_import_goes_to_its_own_layer_or_below():
    assert _layer_violations() == []


def test_no_import_cycle_among_svrqp_modules():
    assert _cycles() == []


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_module_over_600_lines(name):
    assert len(MODULES[name].read_text(encoding="utf-8").splitlines()) <= MAX_MODULE_LINES


def test_functions_are_short_and_take_few_parameters():
    offenders = []
    for name, tree in TREES.items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not _exempt(name, node):
                lines, parameters = _body_lines(node), _parameters(node)
                if lines > MAX_FUNCTION_LINES or parameters > MAX_PARAMETERS:
                    offenders.append(f"{name}.{node.name}: {lines} lines, {parameters} parameters")
    assert offenders == []
