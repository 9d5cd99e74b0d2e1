"""The ``svrqp`` command.

Each subcommand lives in its own module of this package and exposes
``register(app: typer.Typer) -> None``; modules are discovered at start-up, so adding a
command never touches this file. Errors the library raises on purpose are printed as one
line with a non-zero exit code; ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys

import typer

from svrqp.exceptions import SvrqpError

app = typer.Typer(
    name="svrqp",
    help="Support vector regression as explicit convex problems, for machine-tool error modelling.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

_state = {"debug": False}


@app.callback()
def _root(
    debug: bool = typer.Option(False, "--debug", help="Show the full traceback on errors."),
) -> None:
    """Support vector regression as explicit convex problems."""
    _state["debug"] = debug


def _register_commands() -> None:
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        module.register(app)


_register_commands()

# Errors that are the user's to fix: one clear line, exit code 2.
_USER_ERRORS = (SvrqpError, ValueError, KeyError, FileNotFoundError, FileExistsError)


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``svrqp`` console script."""
    try:
        code = app(args=argv, standalone_mode=False)
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
