"""Sim-to-real gap diagnosis: where a model's error on real data concentrates, which
unmodelled effect causes it, and how far it shrinks once that effect is added.

Ask a :class:`GapQuestion` and pass it to :func:`diagnose` (the ``svrqp gap`` command runs
it); the result is a :class:`GapReport` with ``to_json()`` (schema ``svrqp.gap/2``, shipped as
``gap.schema.json``), ``to_html(path)`` and ``to_markdown(path)``; :func:`read_document` reads a
written document back (also one of the previous version, ``svrqp.gap/1``). The method is laid out in
:mod:`svrqp.gap.diagnose`; each step has its own
module or sub-package (CONTRIBUTING.md draws the tree).
"""

from svrqp.gap.diagnose import diagnose
from svrqp.gap.question import GapQuestion
from svrqp.gap.results.document import load_schema, read_document
from svrqp.gap.words.report import GapReport

__all__ = ["GapQuestion", "GapReport", "diagnose", "load_schema", "read_document"]
