"""``python -m svrqp``: the ``svrqp`` command."""

from svrqp.cli import main

main()
