"""The ``svrqp`` group itself: ``--version``, a ``--help`` that imports no command, lazy commands."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys

import click
import numpy as np
import pandas as pd
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
    assert [module for module in commands if not module.rsplit(".", 1)[1].startswith("_")] == []
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
    assert "pygad" in error and "pip install 'svrqp[ga]'" in error
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


def test_tune_fits_only_the_train_rows_and_warns_on_an_edge(tmp_path, capsys):
    """``--train`` selects the rows searched, as in fit and gap; a best C on the grid's edge is named."""
    from svrqp.tuning import grid_search

    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, 80)
    table = pd.DataFrame({"x_mm": x, "error_um": np.sin(6 * x) + 0.01 * rng.normal(size=80),
                          "batch": np.where(np.arange(80) < 50, "a", "b")})
    table.loc[table.batch == "b", "error_um"] += 100.0  # rows that must not be searched
    path = tmp_path / "t.csv"
    table.to_csv(path, index=False)
    main(["tune", str(path), "--target", "error_um", "--features", "x_mm", "--train", "batch == 'a'",
          "--C", "0.01,0.1", "--gamma", "1", "--epsilon", "0.01", "--backend", "sequential",
          "--json", str(tmp_path / "t.json")])
    report = json.loads((tmp_path / "t.json").read_text())
    rows = table[table.batch == "a"]
    with pytest.warns(UserWarning):
        reference = grid_search(rows[["x_mm"]].to_numpy(), rows["error_um"].to_numpy(), C=[0.01, 0.1],
                                gamma=[1.0], epsilon=[0.01])
    assert report["best_mse"] == pytest.approx(reference.best_mse, rel=1e-9)
    assert report["on_edge"] == {"C": "upper"}
    assert "warning: the search ended with C = 0.1 on the upper edge" in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "threads"), [
    ([], 1), (["--blas-threads", "3", "fit"], 3), (["--blas-threads=0", "demo"], 0),
    (["fit", "--blas-threads", "3"], 1),  # after the command's name: not the group's option
    (["--blas-threads", "many"], 1),  # left for the option's own parser to refuse
])
def test_blas_threads_are_read_before_the_command(argv, threads):
    from svrqp.cli import _threads

    assert _threads.requested(argv) == threads


def test_commands_cap_blas_threads_and_restore_the_environment(monkeypatch):
    from threadpoolctl import threadpool_info

    from svrqp.cli import _threads

    for name in _threads.THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("MKL_NUM_THREADS", "7")  # the user's own setting stays
    with _threads.capped(2):
        assert os.environ["OPENBLAS_NUM_THREADS"] == "2" and os.environ["MKL_NUM_THREADS"] == "7"
        assert {pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"} <= {1, 2}
    assert "OPENBLAS_NUM_THREADS" not in os.environ and os.environ["MKL_NUM_THREADS"] == "7"
    with _threads.capped(0):
        assert "OPENBLAS_NUM_THREADS" not in os.environ
