"""The ``svrqp`` command.

Each subcommand lives in its own module of this package and exposes
``register(app: typer.Typer) -> None``, which adds it with ``app.command("name")``; modules are
discovered at start-up, so adding a command never touches this file. A command's module is
imported only when that command runs or shows its own help: ``svrqp --help`` lists the commands
from the modules' source (name and docstring), so it does not load numpy, scikit-learn or
matplotlib. Errors the library raises on purpose are printed as one line with a non-zero exit
code; ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import sys
from pathlib import Path
from typing import Any

import click
import typer
from typer.core import TyperGroup

from svrqp._version import __version__
from svrqp.cli import _threads
from svrqp.exceptions import SvrqpError


def _command_name(node: ast.AST) -> str | None:
    """``"name"`` when ``node`` is the call ``<app>.command("name")``, else None."""
    if (isinstance(node, ast.Call) and isinstance(node.func,
                                                  ast.Attribute) and node.func.attr == "command"
            and node.args and isinstance(node.args[0],
                                         ast.Constant) and isinstance(node.args[0].value, str)):
        return node.args[0].value
    return None


def _declared_in(source: str) -> dict[str, str]:
    """Command name -> docstring of its function, for
    each command that ``register`` in ``source`` adds.

    Both spellings of the project are read: ``@app.command("name")`` on a function defined in
    ``register``, and ``app.command("name")(function)`` on a module-level function.
    """
    tree = ast.parse(source)
    top_level = {node.name: node for node in tree.body if isinstance(node, ast.FunctionDef)}
    declared: dict[str, str] = {}
    if "register" not in top_level:
        return declared
    for node in ast.walk(top_level["register"]):
        if isinstance(node, ast.FunctionDef):
            for decorator in node.decorator_list:
                if name := _command_name(decorator):
                    declared[name] = ast.get_docstring(node) or ""
        elif isinstance(node, ast.Call) and (name := _command_name(node.func)) and node.args:
            function = node.args[0]
            if isinstance(function, ast.Name) and function.id in top_level:
                declared[name] = ast.get_docstring(top_level[function.id]) or ""
    return declared


def declared_commands() -> dict[str, tuple[str, str]]:
    """Command name -> (module of this package, help
    text), read from the source without importing it."""
    commands: dict[str, tuple[str, str]] = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        folder = Path(info.module_finder.path)  # type: ignore[union-attr]
        source = folder / info.name / "__init__.py" if info.ispkg else folder / f"{info.name}.py"
        declared = _declared_in(source.read_text(encoding="utf-8"))
        if not declared:
            raise ImportError(
                f"{__name__}.{info.name}: register(app) adds no app.command(\"name\")"
            )
        commands.update({name: (info.name, help_text) for name, help_text in declared.items()})
    return commands


class _Unloaded(click.Command):
    """A command whose module is not imported yet:
    its name and help, enough for the group's list."""

    def __init__(self, name: str, module: str, help_text: str) -> None:
        super().__init__(name, help=help_text)
        self.module = module


class _LazyGroup(TyperGroup):
    """The ``svrqp`` group: each command's module is
    imported the first time the command is looked up.

    Only the group's own help keeps the :class:`_Unloaded` summaries; every other look-up (running a
    command, its ``--help``, the generated CLI reference) gets the real command.
    """

    def __init__(self, **attrs: Any) -> None:
        super().__init__(**attrs)
        for name, (module, help_text) in declared_commands().items():
            self.commands.setdefault(name, _Unloaded(name, module, help_text))
        self._listing = False

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        command = self.commands.get(cmd_name)
        if isinstance(command, _Unloaded) and not self._listing:
            commands = typer.Typer()
            importlib.import_module(f"{__name__}.{command.module}").register(commands)
            self.commands.update(typer.main.get_group(commands).commands)
            command = self.commands[cmd_name]
        return command

    def format_help(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        self._listing = True
        try:
            super().format_help(ctx, formatter)
        finally:
            self._listing = False


app = typer.Typer(
    name="svrqp",
    cls=_LazyGroup,
    help="Support vector regression as explicit convex problems, for machine-tool error modelling.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

_state = {"debug": False}


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"svrqp {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    debug: bool = typer.Option(False, "--debug", help="Show the full traceback on errors."),
    version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                 help="Print the version of svrqp and exit."),
    blas_threads: int = typer.Option(_threads.DEFAULT, _threads.OPTION, min=0,
                                     help="BLAS/OpenMP threads per process (0: the libraries' own "
                                          "default). "
                                          "One is fastest when a command runs a worker per core."),
) -> None:
    """Support vector regression as explicit convex problems."""
    _state["debug"] = debug


# Errors that are the user's to fix: one clear line, exit code 2.
_USER_ERRORS = (SvrqpError, ValueError, KeyError, FileNotFoundError, FileExistsError)


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``svrqp`` console script."""
    arguments = sys.argv[1:] if argv is None else list(argv)
    try:
        with _threads.capped(_threads.requested(arguments)):
            code = app(args=arguments, prog_name="svrqp", standalone_mode=False)
    except _USER_ERRORS as err:
        if _state["debug"]:
            raise
        message = err.args[0] if isinstance(err, KeyError) and err.args else err
        typer.secho(f"error: {message}", err=True, fg=typer.colors.RED)
        sys.exit(2)
    except (typer.Abort, KeyboardInterrupt):
        typer.secho("aborted", err=True)
        sys.exit(130)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except Exception as click_error:  # click usage errors carry their own exit code
        usage_code = getattr(click_error, "exit_code", None)
        if usage_code is None or _state["debug"]:
            raise
        show = getattr(click_error, "show", None)
        if show is not None:
            show()
        sys.exit(usage_code)
    # Without standalone mode click returns the code of a typer.Exit instead of exiting.
    if isinstance(code, int) and code != 0:
        sys.exit(code)
