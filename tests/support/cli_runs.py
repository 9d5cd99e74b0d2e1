"""Run the ``svrqp`` command line in-process, as the CLI tests do."""

from __future__ import annotations

from svrqp.cli import main


def run(argv: list[str]) -> int:
    """Exit code of ``svrqp ARGV`` (0 when it returns normally)."""
    try:
        main(argv)
    except SystemExit as exit_:
        return int(exit_.code)
    return 0
