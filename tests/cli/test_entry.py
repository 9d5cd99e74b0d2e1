"""The ``svrqp`` group itself: ``--version``, a ``--help`` that imports no command, lazy commands."""

from __future__ import annotations

import importlib
import subprocess
import sys

import click
import pytest
import typer
from typer.testing import CliRunner

import svrqp
from svrqp import cli
from svrqp.cli import app, declared_commands, main

HEAVY = {"sklearn", "scipy", "pandas", "matplotlib", "cvxpy", "qpsolvers"}


def test_version(capsys):
    main(["--version"])
    assert capsys.readouterr().out == f"svrqp {svrqp.__version__}\n"


def _run_cli(*args: str) -> tuple[list[str], set[str], list[str]]:
    """``svrqp ARGS`` in a fresh interpreter: its output lines, the top-level packages and the command
    modules it imported."""
    script = (f"import sys\nfrom svrqp.cli import main\nmain({list(args)!r})\n"
              "print(' '.join(sorted({name.split('.')[0] for name in sys.modules})))\n"
              "print(' '.join(sorted(name for name in sys.modules if name.startswith('svrqp.cli.'))))")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    *output, packages, commands = done.stdout.split("\n")[:-1]
    return output, set(packages.split()), commands.split()


def test_help_imports_no_command_module():
    output, packages, commands = _run_cli("--help")
    assert not packages & HEAVY
    assert commands == []
    for name in declared_commands():
        assert any(line.split()[:2] == ["│", name] for line in output), name


@pytest.mark.parametrize(("command", "option"), [("bench", "--output-dir"), ("tune", "--plot")])
def test_command_help_does_not_load_the_plots(command, option):
    output, packages, commands = _run_cli(command, "--help")
    assert f"svrqp.cli.{command}" in commands and any(option in line for line in output)
    assert "matplotlib" not in packages


def _registered() -> dict[str, click.Command]:
    """Every command as the modules register it, imported: the reference for what the list promises."""
    commands = {}
    for module in dict.fromkeys(module for module, _ in declared_commands().values()):
        target = typer.Typer()
        importlib.import_module(f"svrqp.cli.{module}").register(target)
        commands.update(typer.main.get_group(target).commands)
    return commands


def test_listing_read_from_source_matches_the_registered_commands():
    registered = _registered()
    declared = declared_commands()
    assert list(declared) == list(registered)  # same names, same order as before: module by module
    for name, (_, help_text) in declared.items():
        assert help_text == registered[name].help, name


def test_running_a_command_loads_the_real_one():
    result = CliRunner().invoke(app, ["verify", "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert "An exported model, svrqp.model/1 JSON." in result.output  # an argument only the real command has
    group = typer.main.get_command(app)
    assert not isinstance(group.get_command(None, "verify"), cli._Unloaded)


def test_a_mistyped_command_suggests_every_declared_one(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["tun"])
    assert exit_info.value.code == 2
    assert "Did you mean 'tune'?" in capsys.readouterr().err


def test_both_register_spellings_are_read():
    assert cli._declared_in("x = 1\n") == {}
    assert cli._declared_in("def register(app):\n    pass\n") == {}
    assert cli._declared_in('def register(app):\n    @app.command("x")\n    def f():\n        """Do x."""\n') == {
        "x": "Do x."}
    assert cli._declared_in('def g():\n    """Do g.\n\n    More."""\n\ndef register(app):\n    app.command("g")(g)\n') == {
        "g": "Do g.\n\nMore."}


def test_tune_ga_without_pygad_names_the_extra(tmp_path, monkeypatch, capsys):
    table = tmp_path / "line.csv"
    table.write_text("x_mm,error_um\n" + "".join(f"{i},{0.5 * i}\n" for i in range(12)))
    monkeypatch.setitem(sys.modules, "pygad", None)  # what an environment without the extra sees
    with pytest.raises(SystemExit) as exit_info:
        main(["tune", str(table), "--target", "error_um", "--features", "x_mm", "--method", "ga",
              "--backend", "sequential"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err
    assert "pygad" in error and "pip install 'svrqp[dist]'" in error
    assert "Traceback" not in error


#: What a command's --help must not load: the fitting and plotting stack (seconds of imports).
FITTING_STACK = {"sklearn", "pandas", "matplotlib", "cvxpy", "qpsolvers"}


@pytest.mark.parametrize("command", ["fit", "export", "verify", "simulate", "plot", "gap", "demo"])
def test_command_help_loads_no_fitting_stack(command):
    output, packages, commands = _run_cli(command, "--help")
    assert any("--help" in line for line in output)
    assert not packages & FITTING_STACK, packages & FITTING_STACK


def test_light_help_texts_name_every_valid_value():
    """The help texts are written without loading the estimators; they must still list every choice."""
    from svrqp.cli._common import INTERVAL_HELP, SOLVER_HELP
    from svrqp.cli.export import FORMAT_CHOICES
    from svrqp.estimators.kernel import SOLVERS
    from svrqp.export import FORMATS
    from svrqp.guard.conformal import METHODS

    assert all(f"'{solver}'" in SOLVER_HELP or f" {solver}" in SOLVER_HELP for solver in SOLVERS)
    assert all(method in INTERVAL_HELP for method in METHODS)
    assert FORMAT_CHOICES.split(", ") == list(FORMATS)
