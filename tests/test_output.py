"""The shared safe writer (svrqp.output) and the commands that write through it (issue #39,
findings 17 and 19): FIFOs refused, symbolic links never written through."""

from __future__ import annotations

import json
import os
import threading

import pytest

from svrqp import output
from svrqp.cli import main
from svrqp.exceptions import ProblemError
from svrqp.export import write


def test_new_file_is_written(tmp_path):
    path = output.write_text(tmp_path / "sub" / "a.txt", "one")
    assert path.read_text() == "one"


def test_existing_file_needs_force(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("mine")
    with pytest.raises(FileExistsError, match="--force"):
        output.write_text(path, "theirs")
    assert path.read_text() == "mine"
    output.write_text(path, "theirs", force=True)
    assert path.read_text() == "theirs"


@pytest.mark.parametrize("dangling", [True, False])
def test_symlink_is_refused_then_replaced_never_written_through(tmp_path, dangling):
    target = tmp_path / "elsewhere.txt"
    if not dangling:
        target.write_text("precious")
    link = tmp_path / "out.txt"
    link.symlink_to(target)
    with pytest.raises(FileExistsError, match="symbolic link"):
        output.write_text(link, "new")
    output.write_text(link, "new", force=True)
    assert not link.is_symlink() and link.read_text() == "new"
    assert target.exists() != dangling and (dangling or target.read_text() == "precious")


def _fifo(tmp_path):
    fifo = tmp_path / "m.json"
    os.mkfifo(fifo)
    return fifo


@pytest.mark.parametrize("force", [False, True])
def test_fifo_is_refused_without_blocking(tmp_path, force):
    """#17: ``export --out m.json --force`` with m.json a FIFO blocked forever in open()."""
    fifo = _fifo(tmp_path)
    result: list[BaseException] = []

    def attempt() -> None:
        try:
            output.write_text(fifo, "{}", force=force)
        except BaseException as err:  # noqa: BLE001 - handed to the main thread
            result.append(err)

    worker = threading.Thread(target=attempt, daemon=True)
    worker.start()
    worker.join(5.0)
    assert not worker.is_alive(), "the write blocked on the FIFO"
    assert isinstance(result[0], ProblemError) and "FIFO" in str(result[0])


def exit_code(arguments: list[str]) -> int:
    """The exit status of ``svrqp ARGUMENTS`` (0 when main returns normally)."""
    try:
        main(arguments)
    except SystemExit as exit_:
        return int(exit_.code or 0)
    return 0


def _document():
    import numpy as np

    from svrqp.estimators import LinearLS
    from svrqp.export import build_document

    X = np.random.default_rng(0).normal(size=(20, 2))
    return build_document(LinearLS().fit(X, X[:, 0]), X, X[:, 0])


def test_export_with_force_refuses_a_fifo(tmp_path):
    """#17 through export's own writer."""
    fifo = _fifo(tmp_path)
    with pytest.raises(ProblemError, match="FIFO"):
        write(_document(), fifo, force=True)


@pytest.mark.parametrize("force", [False, True])
def test_simulate_does_not_follow_a_symlink(tmp_path, capsys, force):
    """#19: ``simulate --out o.csv`` created the file where a dangling link pointed (and wrote
    through a link to an existing file with --force)."""
    target = tmp_path / "elsewhere.csv"
    link = tmp_path / "o.csv"
    link.symlink_to(target)
    code = exit_code(["simulate", "thermal", "--out", str(link), *(["--force"] if force else [])])
    assert not target.exists()
    if force:
        assert code == 0 and link.is_file() and not link.is_symlink()
    else:
        assert code != 0 and "symbolic link" in capsys.readouterr().err
        assert link.is_symlink()


@pytest.mark.parametrize("force", [False, True])
def test_tune_json_does_not_follow_a_symlink(tmp_path, capsys, force):
    """#19: ``tune --json t.json`` wrote through a dangling link, or a link to an existing file."""
    data = tmp_path / "d.csv"
    data.write_text("x,y\n" + "".join(f"{i / 10},{(i % 7) / 7}\n" for i in range(30)))
    target = tmp_path / "elsewhere.json"
    target.write_text("precious")
    link = tmp_path / "t.json"
    link.symlink_to(target)
    arguments = ["tune", str(data), "--target", "y", "--features", "x", "--model", "lssvr", "--C", "1,10",
                 "--gamma", "1", "--folds", "3", "--json", str(link), *(["--force"] if force else [])]
    code = exit_code(arguments)
    assert target.read_text() == "precious"
    if force:
        assert code == 0 and not link.is_symlink() and json.loads(link.read_text())
    else:
        assert code != 0 and "symbolic link" in capsys.readouterr().err
