"""``python -m svrqp.cli``: the ``svrqp`` command."""

from svrqp.cli import main

main()
