"""The gap diagnosis over a fleet: one record per machine, many machines in one run.

``svrqp fleet`` (and :func:`run_fleet`) takes the records of a manifest or a glob
(:mod:`~svrqp.fleet.manifest`), diagnoses each through the code path of ``svrqp gap``
(:mod:`~svrqp.fleet.record`), serially or on Dask, streamed and resumable
(:mod:`~svrqp.fleet.run`), and writes the fleet table (:mod:`~svrqp.fleet.table`), the pooled
evidence over records (:mod:`~svrqp.fleet.pooled`) and an HTML page (:mod:`~svrqp.fleet.report`)
(:mod:`~svrqp.fleet.runner` ties them together).
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public name -> the module that defines it; imported on first use, so that ``svrqp gap``
#: (which imports :mod:`svrqp.fleet.record`) does not load pandas, scipy or Dask for its help.
_LAZY = {"Record": "manifest", "read_records": "manifest", "PooledVerdict": "pooled",
         "pool": "pooled", "GapOptions": "record", "diagnose_table": "record",
         "Execution": "run", "FleetResult": "runner", "run_fleet": "runner"}
__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"svrqp.fleet.{_LAZY[name]}"), name)
